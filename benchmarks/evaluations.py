# SPDX-License-Identifier: GPL-3.0-or-later
"""Where the evaluations of f (and of its gradient) go in one run (issue 30).

Wraps the surface's ``f`` and ``gradient`` and charges every call to the
first rdmesh function on the stack outside the oracle, then prints one JSON
line per surface: vertices, evaluations per output vertex, and the share of
each caller::

    python benchmarks/evaluations.py torus 0.05 [--method topological-ball] [--mesh]

``--mesh`` remeshes the surface's marching-cubes mesh (``MeshSurface``)
instead of meshing the function.
"""

from __future__ import annotations

import argparse
import collections
import json
import sys
import time


def _caller() -> str:
    frame = sys._getframe(2)
    while frame is not None:
        name = frame.f_code.co_filename
        if "rdmesh" in name and "oracle.py" not in name and "surfaces/" not in name:
            mod = name.split("rdmesh/")[-1].removesuffix(".py")
            return f"{mod}:{frame.f_code.co_name}"
        frame = frame.f_back
    return "?"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("surface")
    p.add_argument("radius", type=float, help="radius bound = 10 x distance bound")
    p.add_argument("--method", default="boissonnat-oudot")
    p.add_argument("--mesh", action="store_true")
    args = p.parse_args(argv)

    import numpy as np
    import rdmesh
    from rdmesh import surfaces

    surface = surfaces.SURFACES[args.surface].make()
    if args.mesh:
        from skimage import measure

        c, r = surface.centre, surface.radius
        n = 96
        ax = [np.linspace(c[a] - r, c[a] + r, n) for a in range(3)]
        pts = np.stack(np.meshgrid(*ax, indexing="ij"), -1).reshape(-1, 3)
        h = ax[0][1] - ax[0][0]
        v, f, _, _ = measure.marching_cubes(surface.f(pts).reshape(n, n, n), 0.0, spacing=(h,) * 3)
        surface = rdmesh.MeshSurface((v + (c - r), f), name=args.surface)
    counts: collections.Counter = collections.Counter()
    f0, g0 = surface.f, surface.gradient

    def f(pts):
        counts["f " + _caller()] += len(pts)
        return f0(pts)

    def g(pts):
        counts["grad " + _caller()] += len(pts)
        return g0(pts)

    surface.f = f
    if g0 is not None:
        surface.gradient = g
    t = time.perf_counter()
    mesh = rdmesh.mesh_surface(
        surface, radius_bound=args.radius, distance_bound=args.radius / 10, method=args.method
    )
    sec = time.perf_counter() - t
    nv = len(mesh.vertices)
    total = sum(counts.values())
    row = {
        "surface": args.surface,
        "mesh": args.mesh,
        "method": args.method,
        "vertices": nv,
        "seconds": round(sec, 2),
        "per_vertex": round(total / nv, 1),
        "components": mesh.report["components"],
        "euler": mesh.report["euler"],
        "by_caller_per_vertex": {k: round(v / nv, 1) for k, v in counts.most_common(12)},
    }
    print(json.dumps(row))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
