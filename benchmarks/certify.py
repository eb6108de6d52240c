"""Certify mode: its cost against the sampled run, and false certificates on hard cases.

Part 1 (cost): every public surface, written as an expression
(``rdmesh.surfaces.builtin.BUILTIN_EXPRESSIONS``), meshed with the
topological-ball method (``--method`` picks another) at the same criteria
with ``certify=False`` and ``certify=True``, alternating, median of the repeats: time, vertices,
evaluations of f, interval evaluations, what the report proves.

Part 2 (hard cases): small components (1 % of the bounding radius and less),
gaps of 0.2 %, tubes of 2 % thickness, with known topology; each meshed in
certify mode by both methods. A false certificate is ``topology_certified``
on a mesh whose components or Euler characteristics differ from the truth.

    python benchmarks/certify.py [--repeats 2] [--method NAME] [--skip-hard] [--json PATH]
        [--fractions none 20 ...] [--surfaces NAME ...]

Prints markdown tables; writes a JSON record (default
``benchmarks/results/<date>-certify.json``).
"""

from __future__ import annotations

import argparse
import datetime
import json
import logging
import statistics
import time
from pathlib import Path

import rdmesh
from rdmesh.surfaces.builtin import BUILTIN_EXPRESSIONS, SURFACES

log = logging.getLogger("rdmesh.benchmarks")

#: (name, expression, bounding radius, components, Euler characteristics sorted).
HARD = [
    (
        "sphere + 1% sphere",
        "min(x**2+y**2+z**2-1, (x-1.4)**2+(y-0.2)**2+z**2-0.02**2)",
        2.0,
        2,
        [2, 2],
    ),
    (
        "sphere + 0.5% sphere",
        "min(x**2+y**2+z**2-1, (x-1.3)**2+(y-0.1)**2+(z+0.2)**2-0.01**2)",
        2.0,
        2,
        [2, 2],
    ),
    (
        "sphere + two 0.2% specks",
        "min(min(x**2+y**2+z**2-1, (x-1.5)**2+y**2+z**2-0.004**2), "
        "(x+0.6)**2+(y-1.2)**2+(z-0.5)**2-0.004**2)",
        2.0,
        3,
        [2, 2, 2],
    ),
    (
        "two spheres, gap 0.2%",
        "min(sqrt(x**2+y**2+z**2)-1, sqrt((x-2.0064)**2+y**2+z**2)-1)",
        3.2,
        2,
        [2, 2],
    ),
    (
        "two spheres, gap 0.2% (product)",
        "((x-1.0032)**2+y**2+z**2-1)*((x+1.0032)**2+y**2+z**2-1)",
        3.2,
        2,
        [2, 2],
    ),
    (
        "torus, tube 2% thick",
        "(x**2+y**2+z**2+1-0.03**2)**2-4*(x**2+y**2)",
        1.5,
        1,
        [0],
    ),
    (
        "torus + 1% sphere in its hole",
        "min((x**2+y**2+z**2+1-0.3**2)**2-4*(x**2+y**2), x**2+y**2+(z-0.1)**2-0.015**2)",
        1.6,
        2,
        [0, 2],
    ),
]


def _surface(text: str, sphere) -> rdmesh.ImplicitSurface:
    if not isinstance(sphere, tuple):
        sphere = ((0.0, 0.0, 0.0), sphere)
    return rdmesh.ImplicitSurface.from_expression(text, sphere)


def _run(text, sphere, *, certify, **kw) -> dict:
    s = _surface(text, sphere)
    t = time.perf_counter()
    try:
        m = rdmesh.mesh_surface(s, certify=certify, **kw)
    except rdmesh.BudgetExceeded as exc:
        m = exc.mesh
    seconds = time.perf_counter() - t
    rep = m.report
    return {
        "seconds": seconds,
        "vertices": len(m.vertices),
        "evaluations": m.stats["evaluations"],
        "interval_evaluations": m.stats.get("interval_evaluations", 0),
        "components": rep["components"],
        "euler": sorted(rep["euler"]),
        "certified": bool(m.topology_certified),
        "complete": bool(m.complete),
        "levels": {k: v["level"] for k, v in rep["tests"].items()},
        "seeding": rep["seeding"]["level"],
    }


def cost(
    repeats: int,
    method: str = "topological-ball",
    fractions: tuple = (None, 20.0),
    surfaces: tuple | None = None,
) -> list[dict]:
    """Part 1: each public surface (or those named), sampled and certified,
    alternating, with the radius bound R / fraction for each of ``fractions``
    (None: no size bound)."""
    rows = []
    for name, text in BUILTIN_EXPRESSIONS.items():
        if surfaces is not None and name not in surfaces:
            continue
        info = SURFACES[name]
        made = info.make()
        radius = float(made.radius)
        sphere = (tuple(float(c) for c in made.centre), radius)
        for bound in (None if k is None else radius / k for k in fractions):
            runs = {False: [], True: []}
            for r in range(repeats):
                for certify in (False, True) if r % 2 == 0 else (True, False):
                    runs[certify].append(
                        _run(text, sphere, certify=certify, method=method,
                             radius_bound=bound)
                    )  # fmt: skip
            row = {"surface": name, "radius_bound": bound}
            for certify, rs in runs.items():
                key = "certified_mode" if certify else "sampled_mode"
                last = rs[-1]
                row[key] = {
                    **last,
                    "seconds": statistics.median(x["seconds"] for x in rs),
                    "correct": last["components"] == info.components
                    and sum(last["euler"]) == info.euler,
                }
            row["ratio"] = row["certified_mode"]["seconds"] / row["sampled_mode"]["seconds"]
            rows.append(row)
            log.info("%s bound %s: ratio %.2f", name, bound, row["ratio"])
    return rows


def hard() -> list[dict]:
    """Part 2: hard cases, both methods in certify mode."""
    rows = []
    for name, text, radius, comps, euler in HARD:
        for method, bound in (("topological-ball", None), ("boissonnat-oudot", radius / 20)):
            r = _run(text, radius, certify=True, method=method, radius_bound=bound,
                     time_limit=900.0)  # fmt: skip
            r.update(case=name, method=method, radius_bound=bound)
            r["correct"] = r["components"] == comps and r["euler"] == sorted(euler)
            r["false_certificate"] = r["certified"] and not r["correct"]
            rows.append(r)
            log.info("%s %s: correct %s certified %s", name, method, r["correct"], r["certified"])
    return rows


def _markdown(costs: list[dict], cases: list[dict], method: str = "topological-ball") -> str:
    out = [
        f"### Certify mode against the sampled run ({method}, same criteria)",
        "",
        "| surface | radius bound | sampled s | certified s | ratio | vertices (s / c) "
        "| f evals (s / c) | interval evals | certified | topology right (s / c) |",
        "|---|---|---:|---:|---:|---|---|---:|---|---|",
    ]
    for r in costs:
        s, c = r["sampled_mode"], r["certified_mode"]
        bound = "none" if r["radius_bound"] is None else f"{r['radius_bound']:.3g}"
        out.append(
            f"| {r['surface']} | {bound} | {s['seconds']:.2f} | {c['seconds']:.2f} | "
            f"{r['ratio']:.2f} | {s['vertices']} / {c['vertices']} | "
            f"{s['evaluations']} / {c['evaluations']} | {c['interval_evaluations']} | "
            f"{c['certified']} | {s['correct']} / {c['correct']} |"
        )
    if not cases:
        return "\n".join(out)
    out += [
        "",
        "### Hard cases, certify mode",
        "",
        "| case | method | vertices | components | Euler | right | certified | "
        "false certificate | s |",
        "|---|---|---:|---:|---|---|---|---|---:|",
    ]
    for r in cases:
        out.append(
            f"| {r['case']} | {r['method']} | {r['vertices']} | {r['components']} | "
            f"{r['euler']} | {r['correct']} | {r['certified']} | {r['false_certificate']} | "
            f"{r['seconds']:.2f} |"
        )
    n_false = sum(r["false_certificate"] for r in cases)
    n_cert = sum(r["certified"] for r in cases)
    out.append("")
    out.append(f"False certificates: {n_false} of {n_cert} certified runs ({len(cases)} runs).")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--skip-cost", action="store_true", help="only the hard cases")
    ap.add_argument("--skip-hard", action="store_true", help="only the cost part")
    ap.add_argument("--method", default="topological-ball", help="the cost part's method")
    ap.add_argument(
        "--fractions",
        nargs="+",
        default=["none", "20"],
        help="radius bounds of the cost part, as R / fraction ('none': no size bound)",
    )
    ap.add_argument(
        "--surfaces",
        nargs="+",
        choices=sorted(BUILTIN_EXPRESSIONS),
        default=None,
        help="the cost part's surfaces (default: all)",
    )
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    logging.getLogger("rdmesh").setLevel(logging.WARNING)
    try:
        fractions = tuple(None if f == "none" else float(f) for f in args.fractions)
    except ValueError:
        ap.error(f"--fractions takes numbers or 'none', got {args.fractions}")
    if any(f is not None and not f > 0 for f in fractions):
        ap.error("--fractions must be positive")
    costs = [] if args.skip_cost else cost(args.repeats, args.method, fractions, args.surfaces)
    cases = [] if args.skip_hard else hard()
    text = _markdown(costs, cases, args.method)
    print(text)
    path = args.json or Path(__file__).parent / "results" / (
        f"{datetime.date.today().isoformat()}-certify.json"
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    record = {"rdmesh": rdmesh.__version__, "repeats": args.repeats, "method": args.method,
              "cost": costs,
              "hard": cases, "markdown": text}  # fmt: skip
    path.write_text(json.dumps(record, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
