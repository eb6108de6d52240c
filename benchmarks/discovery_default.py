# SPDX-License-Identifier: GPL-3.0-or-later
"""What the proven component search costs when Boissonnat-Oudot runs it by default (issue 30).

For each built-in surface as an expression, ``mesh_surface`` with its
defaults (Boissonnat-Oudot, radius bound R/20) with the search (the default
since issue 30) and without it (the grid scan alone, as before), plus a
sphere of radius 0.02 R beside a large one. Prints a markdown table.

    python benchmarks/discovery_default.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import time

import rdmesh
import rdmesh.refine.methods as methods
from rdmesh.sampling.components import find_components
from rdmesh.surfaces.builtin import BUILTIN_EXPRESSIONS, SURFACES

SMALL_BESIDE_LARGE = (
    "min(x**2 + y**2 + z**2 - 1, (x - 1.3)**2 + (y - 0.3)**2 + (z + 0.2)**2 - 0.04**2)",
    ((0.0, 0.0, 0.0), 2.0),
    2,
)


def cases():
    for name, text in BUILTIN_EXPRESSIONS.items():
        surface = SURFACES[name].make()
        yield name, text, (surface.centre, surface.radius), SURFACES[name].components
    yield ("small sphere 0.02 R beside a large one", *SMALL_BESIDE_LARGE)


def run(text, sphere, search: bool, repeat: int):
    methods.find_components = find_components if search else (lambda *a, **k: None)
    best = None
    for _ in range(repeat):
        s = rdmesh.ImplicitSurface.from_expression(text, sphere)
        t = time.perf_counter()
        m = rdmesh.mesh_surface(s)
        sec = time.perf_counter() - t
        if best is None or sec < best[0]:
            best = (sec, m)
    methods.find_components = find_components
    return best


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    print(
        "| surface | components (want) | with search: s, comps, seeding, seeding s | "
        "grid scan only: s, comps |"
    )
    print("|---|---|---|---|")
    for name, text, sphere, want in cases():
        on_s, on = run(text, sphere, True, args.repeat)
        off_s, off = run(text, sphere, False, args.repeat)
        seed_s = on.stats["phase_seconds"].get("seeding", 0.0)
        print(
            f"| {name} | {want} | {on_s:.2f}, {on.report['components']}, "
            f"{on.report['seeding']['level']}, {seed_s:.2f} | {off_s:.2f}, "
            f"{off.report['components']} |"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
