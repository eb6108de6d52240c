"""Cost of one interval evaluation (f and its gradient, mean-value form) against the
number of boxes, on the core's evaluator (C++) and on the numpy reference of the
same rules (tests/interval_reference.py, which the tests compare the core against).

    python benchmarks/interval_cost.py [--surface torus|all] [--sizes 1 100 3000]

Prints one line per surface and batch size: microseconds per box on each
evaluator and their ratio, the two timed alternately.
"""

from __future__ import annotations

import argparse
import sys
import time
from contextlib import nullcontext
from pathlib import Path
from unittest import mock

import numpy as np
from rdmesh.surfaces import intervals
from rdmesh.surfaces.builtin import BUILTIN_EXPRESSIONS
from rdmesh.surfaces.expressions import parse_expression

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
import interval_reference  # noqa: E402


def _per_box(expr, lo, hi, native: bool, seconds: float) -> float:
    patch = (
        nullcontext()
        if native
        else mock.patch.object(intervals, "_bounds", interval_reference.bounds)
    )
    with patch:
        calls, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < seconds:
            expr.interval_gradient(lo, hi, mean_value=True)
            calls += 1
    return (time.perf_counter() - t0) / calls / len(lo)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--surface", default="torus", choices=[*sorted(BUILTIN_EXPRESSIONS), "all"])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1, 100, 3000, 100_000])
    ap.add_argument("--seconds", type=float, default=0.5, help="time per size and evaluator")
    args = ap.parse_args(argv)
    names = list(BUILTIN_EXPRESSIONS) if args.surface == "all" else [args.surface]
    rng = np.random.default_rng(0)
    print("| surface | boxes | reference µs/box | core µs/box | reference ÷ core |")
    print("|---|---:|---:|---:|---:|")
    for name in names:
        expr = parse_expression(BUILTIN_EXPRESSIONS[name])
        for n in args.sizes:
            # Boxes of mixed sizes in [-2, 2]^3, as the proofs' subdivisions make them.
            centre = rng.uniform(-2, 2, (n, 3))
            half = rng.uniform(0, 0.1, (n, 3))
            lo, hi = centre - half, centre + half
            t = {True: [], False: []}
            for native in (False, True, True, False):
                t[native].append(_per_box(expr, lo, hi, native, args.seconds / 2))
            numpy_, core = min(t[False]), min(t[True])
            ratio = numpy_ / core
            print(f"| {name} | {n} | {numpy_ * 1e6:.2f} | {core * 1e6:.2f} | {ratio:.1f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
