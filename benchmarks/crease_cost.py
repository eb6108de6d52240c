# SPDX-License-Identifier: GPL-3.0-or-later
"""What finding the creases costs beside meshing (issue 28).

For each shape (``box_ball`` from its expression, ``box_hole`` from its CSG
tree of numpy callables, ``box_rotated`` from its expression), rdmesh meshes
the surface with ``features="auto"`` at a radius bound chosen for about
``--vertices`` vertices (edge size the radius bound, distance bound a tenth
of it), and records the search's seconds (``report["creases"]["seconds"]``:
seeds, tracing, corners and, for expressions, the interval octree) beside
the meshing seconds (``stats["seconds"]``: everything after the search) and
their ratio. The search runs on the seeding grid (64 cells across the
bounding ball), so its cost does not grow with the mesh; the ratio falls as
the mesh grows.

Run: ``python benchmarks/crease_cost.py`` (a few minutes); writes
``benchmarks/results/crease-cost-<date>.json`` (``-2``, ... for later runs of
the same day) and prints a markdown table. The radius bound is a rough
estimate: ``--vertices 130000`` gave 91k to 114k vertices on these shapes.
"""

from __future__ import annotations

import argparse
import datetime
import logging
import sys
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import crease_shapes  # noqa: E402
import record  # noqa: E402

log = logging.getLogger("crease_cost")

#: Radius bound giving about 2,300 vertices on each shape (from the features
#: benchmark at 0.1); the bound for n vertices is this times sqrt(2300 / n).
R_AT_2300 = 0.1


def _surface(name: str):
    import rdmesh

    if name in crease_shapes.EXPRESSIONS:
        text = crease_shapes.EXPRESSIONS[name]
        sphere = ((0.2, 0.2, 0.2), 2.4) if name == "box_ball" else ((0.0, 0.0, 0.0), 2.0)
        return rdmesh.ImplicitSurface.from_expression(text, sphere, name=name)
    shape = crease_shapes.SHAPES[name]()
    if shape.csg is not None:
        return shape.csg()
    return rdmesh.ImplicitSurface.from_expression(
        shape.expression, shape.bounding_sphere, name=name
    )


def run(name: str, vertices: int, seed: int = 0) -> dict[str, Any]:
    """One shape meshed for about ``vertices`` vertices; the costs."""
    import rdmesh

    r = R_AT_2300 * (2300.0 / vertices) ** 0.5
    t0 = time.perf_counter()
    m = rdmesh.mesh_surface(
        _surface(name), radius_bound=r, distance_bound=r / 10, edge_size=r, seed=seed
    )
    wall = time.perf_counter() - t0
    creases = m.report["creases"]
    mesh_s = float(m.stats["seconds"])
    return {
        "shape": name,
        "radius_bound": r,
        "vertices": int(len(m.vertices)),
        "curves": creases["curves"],
        "corners": creases["corners"],
        "level": creases["level"],
        "crease_seconds": creases["seconds"],
        "mesh_seconds": mesh_s,
        "wall_seconds": wall,
        "ratio": creases["seconds"] / mesh_s,
        "features_held": bool(m.features is not None and m.features.held),
        "complete": bool(m.complete),
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--shapes", nargs="+", default=["box_ball", "box_hole", "box_rotated"])
    p.add_argument("--vertices", type=int, default=100_000)
    p.add_argument("--out", type=Path, default=HERE / "results")
    p.add_argument("--no-json", action="store_true")
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(message)s", stream=sys.stderr)
    rec: dict[str, Any] = {
        "kind": "crease_cost",
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
        "machine": record.machine_info(),
        "versions": record.package_versions(),
        "target_vertices": args.vertices,
        "runs": [],
    }
    for name in args.shapes:
        rec["runs"].append(run(name, args.vertices))
        log.warning("%s: %s", name, rec["runs"][-1])
    lines = [
        "| shape | vertices | curves | corners | search (s) | meshing (s) | search / meshing |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rec["runs"]:
        lines.append(
            f"| {r['shape']} | {r['vertices']:,} | {r['curves']} | {r['corners']} "
            f"| {r['crease_seconds']:.2f} | {r['mesh_seconds']:.1f} | {100 * r['ratio']:.1f} % |"
        )
    print("\n".join(lines))
    if not args.no_json:
        stem = f"crease-cost-{datetime.date.today().isoformat()}"
        path, k = args.out / f"{stem}.json", 2
        while path.exists():
            path, k = args.out / f"{stem}-{k}.json", k + 1
        record.save(rec, path)
        print(f"\nwrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
