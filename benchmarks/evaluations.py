# SPDX-License-Identifier: GPL-3.0-or-later
"""Where the evaluations of f (and of its gradient) go in one run (issue 30).

Wraps the surface's ``f`` and ``gradient`` and charges every call to the
first rdmesh function on the stack outside the oracle, then prints one JSON
line per run: vertices, evaluations per output vertex (a gradient call counts
one), and the share of each caller::

    python benchmarks/evaluations.py torus 0.05 [--method topological-ball] [--mesh]
    python benchmarks/evaluations.py --all --vertices 100000 [--f-only] \\
        [--radii radii.json] [--out evals.jsonl]

``--mesh`` remeshes the surface's marching-cubes mesh (``MeshSurface``)
instead of meshing the function. ``--all`` runs every public surface at the
radius bound that gives about ``--vertices`` vertices (two runs aim at it,
as ``calibration.py`` does; ``--radii`` keeps the radii in a JSON file, so a
second version can be run at the same ones). ``--f-only`` drops the exact
gradient: central differences of f then count six evaluations each.
"""

from __future__ import annotations

import argparse
import collections
import json
import sys
import time
from pathlib import Path


def _caller() -> str:
    frame = sys._getframe(2)
    while frame is not None:
        name = frame.f_code.co_filename
        if "rdmesh" in name and "oracle.py" not in name and "surfaces/" not in name:
            mod = name.split("rdmesh/")[-1].removesuffix(".py")
            return f"{mod}:{frame.f_code.co_name}"
        frame = frame.f_back
    return "?"


def _surface(name: str, mesh: bool, f_only: bool):
    import numpy as np
    import rdmesh
    from rdmesh import surfaces

    surface = surfaces.SURFACES[name].make()
    if mesh:
        from skimage import measure

        c, r = surface.centre, surface.radius
        n = 96
        ax = [np.linspace(c[a] - r, c[a] + r, n) for a in range(3)]
        pts = np.stack(np.meshgrid(*ax, indexing="ij"), -1).reshape(-1, 3)
        h = ax[0][1] - ax[0][0]
        v, f, _, _ = measure.marching_cubes(surface.f(pts).reshape(n, n, n), 0.0, spacing=(h,) * 3)
        return rdmesh.MeshSurface((v + (c - r), f), name=name)
    if f_only:
        return rdmesh.ImplicitSurface(surface.f, surface.bounding_sphere, name=name)
    return surface


def run(name: str, radius: float, method: str, mesh: bool = False, f_only: bool = False) -> dict:
    """One run with every call of f and of the gradient charged to its caller."""
    import rdmesh

    surface = _surface(name, mesh, f_only)
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
    mesh_out = rdmesh.mesh_surface(
        surface, radius_bound=radius, distance_bound=radius / 10, method=method
    )
    sec = time.perf_counter() - t
    nv = len(mesh_out.vertices)
    return {
        "surface": name,
        "radius": radius,
        "mesh": mesh,
        "f_only": f_only,
        "method": method,
        "vertices": nv,
        "seconds": round(sec, 2),
        "per_vertex": round(sum(counts.values()) / nv, 1),
        "stats_per_vertex": round(mesh_out.stats["evaluations"] / nv, 1),
        "components": mesh_out.report["components"],
        "euler": mesh_out.report["euler"],
        "closed_manifold": bool(mesh_out.is_closed_manifold()),
        "min_angle": round(float(mesh_out.angles.min()), 2),
        "by_caller_per_vertex": {k: round(v / nv, 1) for k, v in counts.most_common(12)},
    }


def _radius_for(name: str, vertices: int, method: str) -> float:
    """The radius bound that gives about ``vertices`` vertices (V ~ 1 / r^2)."""
    import rdmesh

    r = rdmesh.surfaces.SURFACES[name].make().radius / 15.0
    for _ in range(2):
        m = rdmesh.mesh_surface(
            rdmesh.surfaces.SURFACES[name].make(), radius_bound=r, distance_bound=r / 10,
            method=method,
        )  # fmt: skip
        r *= (len(m.vertices) / vertices) ** 0.5
    return float(r)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("surface", nargs="?")
    p.add_argument("radius", nargs="?", type=float, help="radius bound = 10 x distance bound")
    p.add_argument("--method", default="boissonnat-oudot")
    p.add_argument("--mesh", action="store_true")
    p.add_argument("--f-only", action="store_true", help="f alone, no exact gradient")
    p.add_argument("--all", action="store_true", help="every public surface")
    p.add_argument("--vertices", type=int, default=100_000, help="with --all: target size")
    p.add_argument("--radii", type=Path, help="with --all: JSON of radii, read or written")
    p.add_argument("--out", type=Path, help="append the JSON lines here too")
    args = p.parse_args(argv)
    if not args.all and (args.surface is None or args.radius is None):
        p.error("give a surface and a radius, or --all")

    from rdmesh import surfaces

    if args.all:
        radii = {}
        if args.radii is not None and args.radii.exists():
            radii = json.loads(args.radii.read_text())
        for name in surfaces.SURFACES:
            if name not in radii:
                radii[name] = _radius_for(name, args.vertices, args.method)
        if args.radii is not None:
            args.radii.write_text(json.dumps(radii, indent=1))
        jobs = list(radii.items())
    else:
        jobs = [(args.surface, args.radius)]
    for name, radius in jobs:
        row = run(name, radius, args.method, args.mesh, args.f_only)
        line = json.dumps(row)
        print(line, flush=True)
        if args.out is not None:
            with args.out.open("a") as fh:
                fh.write(line + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
