"""rdmesh against CGAL's Surface_mesher (make_surface_mesh) and Mesh_3, same run.

Each surface is meshed with the same criteria (angle 30, radius bound =
fraction x bounding radius, distance bound = radius bound) by rdmesh (numpy
oracle) and by the CGAL reference program (compiled oracle, same CGAL), in
alternation, each run in a fresh process. Medians are reported with the
rdmesh/CGAL time ratio (below 1 means rdmesh is faster).

CGAL is run with its default oracle error bound (1e-3, relative) and with a
tight one (1e-6); rdmesh's crossings are always located to 1e-7 of the local
facet size.

    python benchmarks/bench_vs_cgal.py                 # torus + tanglecube, 0.005 R
    python benchmarks/bench_vs_cgal.py --quick         # coarse, one repeat
    python benchmarks/bench_vs_cgal.py --surfaces torus --fraction 0.0025 --repeats 5
    python benchmarks/bench_vs_cgal.py --quick --methods boissonnat-oudot topological-ball

``--methods`` picks rdmesh's refinement methods (labels ``rdmesh`` and
``rdmesh_tb``), run at the same final criteria; the table's ratio column is
relative to the first one, and with both methods a line gives TB/BO time.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from cgal_runner import build_reference, run_reference  # noqa: E402

#: rdmesh methods and their labels in the tables.
METHOD_LABELS = {"boissonnat-oudot": "rdmesh", "topological-ball": "rdmesh_tb"}

#: CGAL runs: (label, mesher, oracle error bound).
CGAL_RUNS = (
    ("cgal_surface_mesher", "surface_mesher", 1e-3),
    ("cgal_surface_mesher_tight", "surface_mesher", 1e-6),
    ("cgal_mesh_3", "mesh_3", 1e-3),
)


def run_rdmesh_here(
    surface: str, radius: float, method: str = "boissonnat-oudot", workers: int = 1
) -> dict:
    """Mesh in this process and return the figures (used by the child process)."""
    import rdmesh

    s = rdmesh.surfaces.get(surface)
    mesh = rdmesh.mesh_surface(
        s,
        angle_bound=30.0,
        radius_bound=radius,
        distance_bound=radius,
        method=method,
        workers=workers,
    )
    topo = mesh.topology()
    return {
        "seconds": mesh.stats["seconds"],
        "vertices": len(mesh.vertices),
        "faces": len(mesh.faces),
        "evaluations": mesh.stats["evaluations"],
        "rounds": mesh.stats["rounds"],
        "min_angle": mesh.min_angle,
        "closed": topo["closed_manifold"],
        "euler": sum(topo["euler"]),
        "components": topo["components"],
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "phase_seconds": mesh.stats["phase_seconds"],
        "method": method,
        "workers": workers,
        "tbp_holds": mesh.report["tbp_holds"],
    }


def run_rdmesh(
    surface: str, radius: float, method: str = "boissonnat-oudot", workers: int = 1
) -> dict:
    out = subprocess.run(
        [sys.executable, __file__, "--child", surface, repr(radius), method, str(workers)],
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--surfaces", nargs="+", default=["torus", "tanglecube"])
    p.add_argument("--fraction", type=float, default=0.005, help="radius bound / bounding radius")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--quick", action="store_true", help="fraction 0.02, one repeat")
    p.add_argument("--no-mesh3", action="store_true", help="skip Mesh_3")
    p.add_argument("--json", type=Path, help="also write all runs to this file")
    p.add_argument(
        "--methods",
        nargs="+",
        choices=list(METHOD_LABELS),
        default=["boissonnat-oudot"],
        help="rdmesh methods to run (default: boissonnat-oudot)",
    )
    p.add_argument("--no-cgal", action="store_true", help="run rdmesh only")
    p.add_argument(
        "--workers", nargs="+", type=int, default=[1], help="rdmesh worker threads to try"
    )
    p.add_argument("--child", nargs=4, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child:
        name, radius, method, workers = args.child
        print(json.dumps(run_rdmesh_here(name, float(radius), method, int(workers))))
        return 0
    if args.quick:
        args.fraction, args.repeats = 0.02, 1

    import rdmesh

    exe = None if args.no_cgal else build_reference()
    runs = (
        [] if args.no_cgal else [r for r in CGAL_RUNS if not (args.no_mesh3 and r[1] == "mesh_3")]
    )
    mine = [
        (METHOD_LABELS[m] + (f"_w{w}" if w > 1 else ""), "rdmesh", (m, w))
        for m in dict.fromkeys(args.methods)
        for w in dict.fromkeys(args.workers)
    ]
    results: dict[str, dict[str, list[dict]]] = {}
    for surface in args.surfaces:
        radius = args.fraction * rdmesh.surfaces.get(surface).radius
        per = results.setdefault(surface, {})
        for rep in range(args.repeats):
            # Alternate the order so drift on a shared machine hits all alike.
            order = [*mine, *runs]
            if rep % 2:
                order.reverse()
            for label, mesher, eb in order:
                t = time.perf_counter()
                if mesher == "rdmesh":
                    r = run_rdmesh(surface, radius, *eb)
                else:
                    r = run_reference(exe, mesher, surface, 30.0, radius, radius, error_bound=eb)
                r["wall_with_startup"] = time.perf_counter() - t
                per.setdefault(label, []).append(r)
                print(
                    f"  {surface:11s} {label:26s} {r['seconds']:8.2f} s "
                    f"{r['vertices']:8d} vertices",
                    file=sys.stderr,
                )
        report(surface, radius, per, [m[0] for m in mine])
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    return 0


def report(surface: str, radius: float, per: dict[str, list[dict]], mine: list[str]) -> None:
    first = mine[0]
    base = statistics.median(r["seconds"] for r in per[first])
    print(f"\n{surface}: angle 30, radius = distance = {radius:g}, medians of {len(per[first])}")
    print(f"{'mesher':28s} {'seconds':>9s} {'vertices':>9s} {'vert/s':>9s} {first + '/x':>9s}")
    for label, rs in per.items():
        sec = statistics.median(r["seconds"] for r in rs)
        nv = int(statistics.median(r["vertices"] for r in rs))
        ratio = base / sec
        print(f"{label:28s} {sec:9.2f} {nv:9d} {nv / sec:9.0f} {ratio:9.2f}")
    for label in mine:
        last = per[label][-1]
        print(
            f"{label}: closed manifold {last['closed']}, components {last['components']}, "
            f"Euler {last['euler']}, min angle {last['min_angle']:.2f}, "
            f"{last['evaluations'] / last['vertices']:.0f} evaluations/vertex, "
            f"peak RSS {last['peak_rss_mb']:.0f} MB, TBP certified {last.get('tbp_holds')}"
        )
    if "rdmesh" in per and "rdmesh_tb" in per:
        bo = statistics.median(r["seconds"] for r in per["rdmesh"])
        tb = statistics.median(r["seconds"] for r in per["rdmesh_tb"])
        print(f"topological-ball / boissonnat-oudot time: {tb / bo:.2f}")


if __name__ == "__main__":
    sys.exit(main())
