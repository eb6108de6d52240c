#!/usr/bin/env python
# SPDX-License-Identifier: GPL-3.0-or-later
"""Fingerprints of a fixed set of runs, to check that a change keeps the meshes.

Five built-in surfaces, with and without the exact gradient (f alone), each
meshed once; one line per run: vertices, a hash of the vertices and faces, a
hash of the topology report, and the vertices themselves saved (``--save
DIR``) for a closer comparison. Run it with each version installed and
compare the lines::

    python benchmarks/mesh_hashes.py [--save DIR]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

RUNS = [
    ("torus", {"radius_bound": 0.03, "distance_bound": 0.03}),
    ("tanglecube", {"radius_bound": 0.08, "distance_bound": 0.08}),
    ("two_spheres", {"radius_bound": 0.05, "distance_bound": 0.05}),
    ("double_torus", {"method": "topological-ball", "radius_bound": 0.05}),
    ("blob_line", {"radius_bound": 0.04, "distance_bound": 0.04}),
]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--save", type=Path, default=None, help="save each run's mesh (.npz) here")
    args = ap.parse_args(argv)
    import numpy as np
    import rdmesh
    from rdmesh import surfaces

    for name, kw in RUNS:
        made = surfaces.get(name)
        for grad in (True, False):
            s = made if grad else rdmesh.ImplicitSurface(made.f, made.bounding_sphere)
            m = rdmesh.mesh_surface(s, **kw)
            mesh = hashlib.sha256(m.vertices.tobytes() + m.faces.tobytes()).hexdigest()[:16]
            report = json.dumps(m.report, sort_keys=True, default=str).encode()
            tag = f"{name}-{'grad' if grad else 'f'}"
            print(tag, len(m.vertices), mesh, hashlib.sha256(report).hexdigest()[:12], flush=True)
            if args.save is not None:
                args.save.mkdir(parents=True, exist_ok=True)
                np.savez(args.save / f"{tag}.npz", vertices=m.vertices, faces=m.faces)
    return 0


if __name__ == "__main__":
    sys.exit(main())
