#!/usr/bin/env python
# SPDX-License-Identifier: GPL-3.0-or-later
"""Where one rdmesh run spends its time, and how much CPU it uses.

Meshes a built-in surface with radius bound = distance bound = r, and prints
for each run the wall time, the CPU time of the process over the run (both
threads: Python's and the C++ core's), its ratio to the wall time, the
evaluations of f, the process's peak RSS so far and ``stats["phase_seconds"]``::

    python benchmarks/profile_run.py torus 0.01096 --repeats 3 [--f-only]

``--f-only`` gives the surface's f alone (gradients by central differences),
as most users write it. The facets evaluated and the facets whose status the
core derived itself (``facets_reused``) are printed too.

The CPU time bounds what any overlap of the two cores can reach: on a machine
with c cores a run cannot take less than CPU / c.
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import time


def _cpu() -> float:
    u = resource.getrusage(resource.RUSAGE_SELF)
    return u.ru_utime + u.ru_stime


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("surface", help="a built-in surface (rdmesh.surfaces)")
    p.add_argument("radius", type=float, help="radius bound = distance bound")
    p.add_argument("--repeats", type=int, default=1)
    p.add_argument("--method", default="boissonnat-oudot")
    p.add_argument("--f-only", action="store_true", help="f alone, no exact gradient")
    args = p.parse_args(argv)

    import rdmesh
    from rdmesh import surfaces

    try:
        make = surfaces.SURFACES[args.surface].make
    except KeyError:
        p.error(f"unknown surface {args.surface!r}; use one of {', '.join(surfaces.SURFACES)}")
    if not args.radius > 0:
        p.error("radius must be positive")
    for _ in range(max(1, args.repeats)):
        surface = make()
        if args.f_only:
            surface = rdmesh.ImplicitSurface(surface.f, surface.bounding_sphere)
        c0, t0 = _cpu(), time.perf_counter()
        mesh = rdmesh.mesh_surface(
            surface, radius_bound=args.radius, distance_bound=args.radius, method=args.method
        )
        wall, cpu = time.perf_counter() - t0, _cpu() - c0
        s = mesh.stats
        row = {
            "surface": args.surface,
            "vertices": s["vertices"],
            "wall_s": round(wall, 3),
            "cpu_s": round(cpu, 3),
            "cpu_per_wall": round(cpu / wall, 2),
            "evaluations_per_vertex": round(s["evaluations"] / s["vertices"], 1),
            "facets_evaluated": s["facets_evaluated"],
            "facets_reused": s.get("facets_reused", 0),
            # High-water mark of the process: the first repeat's is that run's peak.
            "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
            "phase_seconds": s["phase_seconds"],
        }
        print(json.dumps(row), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
