#!/usr/bin/env python
# SPDX-License-Identifier: GPL-3.0-or-later
"""The rdmesh benchmark suite: rdmesh against CGAL, pygalmesh and marching cubes.

One command runs every mesher on every surface at every size, repeated, and
writes ``<out>/<date>.json`` (all runs), ``<out>/<date>.md`` (the report) and
``<out>/<date>-*.png`` (plots)::

    python benchmarks/suite.py                     # 8 surfaces x 1e4, 1e5, 1e6 (hours)
    python benchmarks/suite.py --quick             # 3 surfaces, small sizes, 1 repeat (< 2 min)
    python benchmarks/suite.py --surfaces torus tanglecube --sizes 1e4 1e5 --repeats 5
    python benchmarks/suite.py --inputs volume remesh clipped --sizes 1e4 --repeats 1

``--inputs`` adds the other inputs of issue 15 as rows (default: the
built-in implicit surfaces only): volumes (``input_volume.py``), triangle
meshes to remesh (``input_remesh.py``) and surfaces clipped by their
bounding sphere (``input_clipped.py``), each with its own meshers, quality
table and plots.

This file is the command line only; the work is done by

- ``meshers.py``: the meshers (rdmesh, the CGAL reference's Surface_mesher
  and Mesh_3 with and without ``manifold()``, pygalmesh, marching cubes, and
  the floor: CGAL's bulk Delaunay build of rdmesh's vertices): one adapter
  each, and the child-process side that runs a Python mesher and prints one
  JSON line;
- ``runner.py``: the run loop (cases, repeats, skipping, quality once per
  case, the JSON written after every run);
- ``measure.py``: one run in a fresh process (wall time, peak RSS from
  ``wait4``, timeout);
- ``calibration.py``: target vertex count -> radius bound, per surface;
- ``quality.py`` (with ``metrics.py``): angles, topology, Hausdorff distance;
- ``record.py``: the JSON record; ``meshfile.py``: the meshes runs write;
- ``inputs.py`` (with ``input_volume.py``, ``input_remesh.py``,
  ``input_clipped.py``): the other inputs' cases, meshers and quality;
- ``report.py`` (with ``report_inputs.py``) and ``plots.py``: the markdown
  report and the PNG plots.

See benchmarks/README.md for what is measured and how.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

import report  # noqa: E402
from cgal_runner import SURFACES as ALL_SURFACES  # noqa: E402
from inputs import INPUTS, kind  # noqa: E402
from meshers import MESHERS, child_main  # noqa: E402
from record import fmt_size  # noqa: E402
from runner import Suite  # noqa: E402

DEFAULT_SIZES = (1e4, 1e5, 1e6)
QUICK_SIZES = (2e3, 1e4)
QUICK_SURFACES = ("sphere", "torus", "tanglecube")


# ---------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------


def _size(text: str) -> int:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(v) or v < 100:
        raise argparse.ArgumentTypeError(f"a size is a vertex count >= 100, got {text!r}")
    return int(round(v))


def _positive(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text!r}")
    return v


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        prog="suite.py",
        description="rdmesh against CGAL, pygalmesh and marching cubes: tables and plots.",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help=f"sizes {' '.join(fmt_size(s) for s in QUICK_SIZES)}, surfaces "
        f"{' '.join(QUICK_SURFACES)}, 1 repeat, short timeouts (< 2 min)",
    )
    p.add_argument(
        "--surfaces",
        nargs="+",
        choices=ALL_SURFACES,
        metavar="NAME",
        help=f"default: all ({' '.join(ALL_SURFACES)})",
    )
    p.add_argument(
        "--sizes",
        nargs="+",
        type=_size,
        metavar="N",
        help="target vertex counts, default 1e4 1e5 1e6",
    )
    p.add_argument(
        "--inputs",
        nargs="+",
        choices=INPUTS,
        default=["implicit"],
        metavar="INPUT",
        help=f"what is meshed: {' '.join(INPUTS)} (default: implicit, the built-in surfaces)",
    )
    p.add_argument(
        "--cases",
        nargs="+",
        choices=_input_cases(),
        metavar="NAME",
        help="cases of the other inputs to run (default: all of them; quote names "
        f"with spaces): {', '.join(_input_cases())}",
    )
    p.add_argument(
        "--meshers",
        nargs="+",
        choices=MESHERS + _input_only_meshers(),
        metavar="NAME",
        help=f"default: all ({' '.join(MESHERS)}; the other inputs: all of theirs, "
        f"among them {' '.join(_input_only_meshers())})",
    )
    p.add_argument("--repeats", type=int, help="runs per case, median reported (default 3)")
    p.add_argument("--out", default=str(HERE / "results"), help="output directory")
    p.add_argument("--timeout", type=_positive, help="seconds per run (default 3600)")
    p.add_argument("--angle", type=_positive, default=30.0, help="angle bound, degrees")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--cgal-error-bound",
        type=_positive,
        default=1e-6,
        help="relative error bound of CGAL's implicit oracle (default 1e-6)",
    )
    p.add_argument(
        "--pygalmesh-python",
        default=sys.executable,
        help="Python interpreter that imports pygalmesh and rdmesh",
    )
    p.add_argument(
        "--pygalmesh-max-size", type=_size, help="largest size run with pygalmesh (default 1e5)"
    )
    p.add_argument(
        "--certified-max-size",
        type=_size,
        help="largest size run with rdmesh_certified (certify mode; default 1e5)",
    )
    p.add_argument(
        "--pygalmesh-repeats",
        type=int,
        default=1,
        help="runs of pygalmesh per case (default 1: it is slow)",
    )
    p.add_argument(
        "--pygalmesh-timeout",
        type=_positive,
        help="seconds per pygalmesh run (default: --timeout)",
    )
    p.add_argument(
        "--reference-samples",
        type=int,
        help="surface points for the Hausdorff distance (default 1e6)",
    )
    p.add_argument(
        "--memory-limit-gb",
        type=_positive,
        help="cap each run's address space (RLIMIT_AS); default: none",
    )
    p.add_argument("--recalibrate", action="store_true", help="ignore the calibration cache")
    p.add_argument("--child", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child:
        return args
    q = args.quick
    if args.surfaces is None:
        args.surfaces = list(QUICK_SURFACES if q else ALL_SURFACES)
    if args.sizes is None:
        args.sizes = [int(s) for s in (QUICK_SIZES if q else DEFAULT_SIZES)]
    if args.repeats is None:
        args.repeats = 1 if q else 3
    if args.repeats < 1:
        p.error("--repeats must be >= 1")
    if args.timeout is None:
        args.timeout = 60.0 if q else 3600.0
    if args.pygalmesh_max_size is None:
        args.pygalmesh_max_size = min(args.sizes) if q else 100_000
    if args.certified_max_size is None:
        args.certified_max_size = min(args.sizes) if q else 100_000
    if args.reference_samples is None:
        args.reference_samples = 50_000 if q else 1_000_000
    if args.reference_samples < 1000:
        p.error("--reference-samples must be >= 1000")
    # Keep the user's order but drop duplicates.
    args.surfaces = list(dict.fromkeys(args.surfaces))
    args.inputs = list(dict.fromkeys(args.inputs))
    # --meshers picks the built-in surfaces' meshers and filters the other
    # inputs' (None: all of theirs).
    given = list(dict.fromkeys(args.meshers)) if args.meshers else None
    args.input_meshers = given
    args.meshers = [m for m in given if m in MESHERS] if given else list(MESHERS)
    if "implicit" in args.inputs and not args.meshers:
        p.error(f"--meshers names none of the built-in surfaces' meshers ({' '.join(MESHERS)})")
    return args


def _input_cases() -> list[str]:
    return [c for name in INPUTS[1:] for c in kind(name).cases()]


def _input_only_meshers() -> tuple[str, ...]:
    seen = [m for name in INPUTS[1:] for m in kind(name).meshers if m not in MESHERS]
    return tuple(dict.fromkeys(seen))


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.child:
        return child_main(json.loads(args.child))
    suite = Suite(args)
    t0 = time.perf_counter()
    interrupted = False
    try:
        suite.run()
    except KeyboardInterrupt:
        interrupted = True
        suite.log("interrupted: writing what has been measured so far")
    suite.results["seconds"] = time.perf_counter() - t0
    files = suite.finish()
    print(report.tables(suite.results))
    print()
    for what, path in files.items():
        print(f"{what}: {path}")
    print(f"total {suite.results['seconds']:.0f} s")
    return 130 if interrupted else 0


if __name__ == "__main__":
    sys.exit(main())
