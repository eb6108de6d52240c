"""Cost of one interval evaluation (f and its gradient, mean-value form) against the
number of boxes: the fixed cost per call and the cost per box.

    python benchmarks/interval_cost.py [--surface torus]

Prints one line per batch size: milliseconds per call, microseconds per box.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from rdmesh.surfaces.builtin import BUILTIN_EXPRESSIONS
from rdmesh.surfaces.expressions import parse_expression


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--surface", default="torus", choices=sorted(BUILTIN_EXPRESSIONS))
    ap.add_argument("--seconds", type=float, default=1.0, help="time per batch size")
    args = ap.parse_args(argv)
    expr = parse_expression(BUILTIN_EXPRESSIONS[args.surface])
    rng = np.random.default_rng(0)
    for n in (1, 100, 1000, 10_000, 100_000):
        lo = rng.uniform(-1, 1, (n, 3))
        hi = lo + 0.01
        calls, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < args.seconds:
            expr.interval_gradient(lo, hi, mean_value=True)
            calls += 1
        dt = (time.perf_counter() - t0) / calls
        print(f"{n:>7} boxes: {dt * 1e3:8.2f} ms per call, {dt / n * 1e6:9.2f} us per box")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
