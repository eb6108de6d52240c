#!/usr/bin/env python
# SPDX-License-Identifier: GPL-3.0-or-later
"""How the layout of a numpy f changes its cost: rows of (N, 3) against columns.

Times two ways of writing the same f on the same points (best of 5 x 20
calls), as rdmesh calls it: one (N, 3) float64 array per call::

    python benchmarks/f_layout.py [--points 150000]
"""

from __future__ import annotations

import argparse
import sys
import timeit

import numpy as np

C = 1.05  # two_spheres' centres at +-C on the x axis


def tanglecube_rows(p):
    q = p * p
    return (q * q - 5.0 * q).sum(axis=1) + 11.8


def tanglecube_columns(p):
    x, y, z = p.T
    x2, y2, z2 = x * x, y * y, z * z
    return x2 * (x2 - 5.0) + y2 * (y2 - 5.0) + z2 * (z2 - 5.0) + 11.8


def two_spheres_rows(p):
    a, b = p - (C, 0, 0), p + (C, 0, 0)
    return (np.einsum("ij,ij->i", a, a) - 1.0) * (np.einsum("ij,ij->i", b, b) - 1.0)


def two_spheres_columns(p):
    x, y, z = p.T
    q = y * y + z * z - 1.0
    return ((x - C) * (x - C) + q) * ((x + C) * (x + C) + q)


PAIRS = {
    "tanglecube": (tanglecube_rows, tanglecube_columns),
    "two_spheres": (two_spheres_rows, two_spheres_columns),
}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, default=150_000)
    args = ap.parse_args(argv)
    if args.points < 1:
        ap.error("--points must be positive")
    p = np.random.default_rng(0).normal(size=(args.points, 3))
    print("| f | rows (ms) | columns (ms) | rows ÷ columns |\n|---|---:|---:|---:|")
    for name, (rows, cols) in PAIRS.items():
        if not np.allclose(rows(p), cols(p), rtol=1e-12, atol=1e-9):
            raise SystemExit(f"{name}: the two forms disagree")
        t = [
            min(timeit.repeat(lambda g=g: g(p), number=20, repeat=5)) / 20 * 1e3
            for g in (rows, cols)
        ]
        print(f"| {name} | {t[0]:.2f} | {t[1]:.2f} | {t[0] / t[1]:.1f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
