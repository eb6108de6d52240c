#!/usr/bin/env python
# SPDX-License-Identifier: GPL-3.0-or-later
"""Fuzz rdmesh with random smooth surfaces of known topology (the large profile).

Draws N surfaces from the families of ``tests/fuzz_surfaces.py`` (round-robin,
case i drawn from ``numpy.random.default_rng([seed, i])``), meshes each with
both methods under a vertex budget and a time limit, and prints and writes
the figures::

    python benchmarks/fuzz.py --cases 120 --seed 1
    python benchmarks/fuzz.py --cases 12 --seed 1 --profile fast --families dumbbell

Figures, per run (one surface, one method):

- ``correct``: a closed manifold with the reference topology;
- ``wrong_flagged``: wrong topology (or not a closed manifold), not certified;
- ``wrong_certified``: wrong topology yet ``topology_certified`` (must be 0);
- ``budget_stops``: BudgetExceeded (with its partial mesh);
- ``clear_errors``: an rdmesh error or ValueError on a valid surface;
- ``crashes``: any other exception;
- ``hangs``: wall time above twice the time limit (or the watchdog fired);
- ``property_failures``: runs that break an asserted property (angle, vertices
  on the surface, closed manifold when complete, ball radius, certified but
  wrong), listed in full in the JSON;

and per surface ``ambiguous_references``: marching cubes at two resolutions
disagreed (or cannot see a small blob), so the topology is not judged (the
surface is still meshed), and ``certified_disagreements``: both methods
certified, but different topologies (one certificate is false; this needs no
reference, so it also catches ambiguous cases).
Each case line carries the ``spec`` that rebuilds the surface
(``import fuzz_surfaces as fz; fz.dumbbell(...)``).
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from collections import Counter
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

import fuzz_surfaces as fz  # noqa: E402


def run(cases: int, seed: int, profile: fz.Profile, families: list[str], log) -> dict:
    records, surfaces = [], []
    t_start = time.perf_counter()
    for i in range(cases):
        family = families[i % len(families)]
        rng = np.random.default_rng([seed, i])
        t0 = time.perf_counter()
        try:
            surf = fz.generate(family, rng, profile)
            ref = surf.reference
        except Exception as exc:  # noqa: BLE001 - a generator bug must not stop the run
            surfaces.append({"case": i, "family": family, "generator_error": repr(exc)})
            log(f"[{i}] {family}: generator error {exc!r}")
            continue
        entry = {
            "case": i,
            "family": family,
            "name": surf.name,
            "spec": surf.spec,
            "feature": surf.feature,
            "reference": None
            if ref.topology is None
            else {"components": ref.topology.components, "euler": list(ref.topology.euler)},
            "reference_source": ref.source,
            "reference_detail": ref.detail,
            "reference_seconds": time.perf_counter() - t0,
        }
        surfaces.append(entry)
        outcomes = []
        for method in fz.METHODS:
            out = fz.run_method(surf, method, profile)
            outcomes.append(out)
            rec = out.as_dict()
            rec.update(case=i, family=family, failures=out.failures())
            rec["hang"] = out.status == "hang" or out.seconds > 2 * out.time_limit
            records.append(rec)
            topo = out.topology
            log(
                f"[{i}] {surf.name} {method}: {rec['category']}"
                + (f" ({out.exception[:100]})" if out.exception else "")
                + f", {out.vertices} vertices, {out.seconds:.1f} s"
                + (f", got {topo.components} {list(topo.euler)}" if topo else "")
                + (f", certified={out.certified}" if out.status in ("ok", "budget") else "")
                + (f"; FAILS {out.failures()}" if out.failures() else "")
            )
        entry["certified_disagreement"] = fz.certified_disagreement(outcomes)
        if entry["certified_disagreement"]:
            log(f"[{i}] {surf.name}: the two methods certify different topologies")
        if entry["certified_disagreement"] or any(
            r["failures"] or r["category"] in ("crash", "wrong-certified") for r in records[-2:]
        ):
            log(f"    spec: {surf.spec}")
    cat = Counter(r["category"] for r in records)
    figures = {
        "cases": sum(1 for s in surfaces if "spec" in s),
        "runs": len(records),
        "correct": cat["correct"],
        "wrong_flagged": cat["wrong-flagged"],
        "wrong_certified": cat["wrong-certified"],
        "budget_stops": cat["budget"],
        "clear_errors": cat["error"],
        "crashes": cat["crash"],
        "hangs": sum(r["hang"] for r in records),
        "property_failures": sum(bool(r["failures"]) for r in records),
        "ambiguous_references": sum(1 for s in surfaces if "spec" in s and s["reference"] is None),
        "certified_disagreements": sum(bool(s.get("certified_disagreement")) for s in surfaces),
        "ambiguous_runs": cat["ambiguous"],
        "generator_errors": sum(1 for s in surfaces if "generator_error" in s),
        "certified_runs": sum(r["certified"] for r in records),
        "radius_clipped_runs": sum(r["radius_clipped"] for r in records),
        "seconds": time.perf_counter() - t_start,
    }
    by_method = {
        m: dict(Counter(r["category"] for r in records if r["method"] == m)) for m in fz.METHODS
    }
    by_family = {
        f: dict(Counter(r["category"] for r in records if r["family"] == f)) for f in families
    }
    return {
        "figures": figures,
        "by_method": by_method,
        "by_family": by_family,
        "surfaces": surfaces,
        "runs": records,
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", type=int, default=60, help="surfaces to draw (default 60)")
    p.add_argument("--seed", type=int, default=0, help="seed of the draws (default 0)")
    p.add_argument("--profile", choices=sorted(fz.PROFILES), default="large")
    p.add_argument("--families", nargs="+", choices=list(fz.FAMILIES), default=list(fz.FAMILIES))
    p.add_argument(
        "--out", type=Path, default=None, help="JSON file (default benchmarks/results/tmp/...)"
    )
    p.add_argument("--quiet", action="store_true", help="print only the figures")
    args = p.parse_args(argv)
    profile = fz.PROFILES[args.profile]

    def log(line: str) -> None:
        if not args.quiet:
            print(line, flush=True)

    result = run(args.cases, args.seed, profile, args.families, log)
    result["command"] = " ".join(["python benchmarks/fuzz.py", *(argv or sys.argv[1:])])
    result["profile"] = profile.__dict__
    result["date"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
    result["machine"] = {"python": platform.python_version(), "platform": platform.platform()}
    out = args.out or ROOT / "benchmarks" / "results" / "tmp" / (
        f"fuzz-{args.profile}-seed{args.seed}-n{args.cases}.json"
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=1, default=float))
    print(json.dumps(result["figures"], indent=1))
    print("by method:", json.dumps(result["by_method"]))
    print("by family:", json.dumps(result["by_family"]))
    print(f"written {out}")
    fig = result["figures"]
    return 1 if fig["wrong_certified"] or fig["crashes"] or fig["certified_disagreements"] else 0


if __name__ == "__main__":
    sys.exit(main())
