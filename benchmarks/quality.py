# SPDX-License-Identifier: GPL-3.0-or-later
"""The quality of one output mesh: angles, topology, Hausdorff distance (``metrics.py``).

The Hausdorff distance needs reference points on the surface, which are
computed once per surface and point count and cached as ``.npy`` files.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from meshfile import load_mesh

__all__ = ["QualityMeter"]


class QualityMeter:
    """Measures meshes against their surface; keeps one surface's reference points.

    ``cache``: where reference points are stored; ``reference_samples``: how
    many; ``angle``: the angle bound the angle statistics count against;
    ``seed``: of the random mesh samples.
    """

    def __init__(
        self,
        cache: Path,
        reference_samples: int,
        angle: float,
        seed: int,
        log: Callable[[str], None] = lambda msg: None,
    ) -> None:
        self.cache = cache
        self.reference_samples = int(reference_samples)
        self.angle = angle
        self.seed = seed
        self.log = log
        self.references: dict[str, Any] = {}

    def reference(self, surface: str, bbox) -> Any:
        """(n, 3) points on ``surface`` (``metrics.surface_reference``), cached."""
        import numpy as np
        import rdmesh
        from metrics import surface_reference

        if surface in self.references:
            return self.references[surface]
        n = self.reference_samples
        path = self.cache / f"reference-{surface}-{n}.npy"
        if path.exists():
            ref = np.load(path)
        else:
            self.log(f"reference points on {surface} ({n}) ...")
            s = rdmesh.surfaces.get(surface)
            ref = surface_reference(s, n, (np.array(bbox[0]), np.array(bbox[1])))
            np.save(path, ref)
        self.references = {surface: ref}  # keep one surface in memory
        return ref

    def measure(self, surface: str, mesh_file: str, bbox) -> dict[str, Any]:
        """The ``quality`` entry of a case, from the mesh a run wrote.

        ``bbox``: (lo, hi) around the surface, where the reference points are made.
        """
        import rdmesh
        from metrics import angle_stats, compact, hausdorff, mesh_area, topology_stats

        t0 = time.perf_counter()
        v, f = compact(*load_mesh(mesh_file))
        info = rdmesh.surfaces.SURFACES[surface]
        q: dict[str, Any] = {"vertices": int(len(v)), "faces": int(len(f))}
        q.update(angle_stats(v, f, self.angle))
        q["topology"] = topology_stats(v, f, info.components, info.euler)
        if len(f):
            q["area"] = mesh_area(v, f)
            ref = self.reference(surface, bbox)
            q["hausdorff"] = hausdorff(rdmesh.surfaces.get(surface), v, f, ref, seed=self.seed)
        else:
            q["hausdorff"] = None
        q["seconds"] = time.perf_counter() - t0
        return q
