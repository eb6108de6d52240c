# SPDX-License-Identifier: GPL-3.0-or-later
"""The run loop of the benchmark suite.

For every surface: calibrate; for every size: a case per mesher, run
``--repeats`` times (the mesher order reversed every other repeat), each run
a fresh process measured by ``measure.run_measured``; quality measured once
per case on the first successful run's mesh; the JSON record written after
every run.  Failures and timeouts are recorded, not raised.

The other inputs (``--inputs volume remesh clipped``, ``inputs.py``) run
the same way after the built-in surfaces: for every case of the input and
every size, a case per mesher of that input, with the input's parameters
and quality measurement.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import os
import re
import sys
from pathlib import Path
from typing import Any

import inputs
import record
from calibration import cached_calibration, calibration_target
from measure import run_measured
from meshers import FLOOR, Mesher, adapters
from quality import QualityMeter

__all__ = ["Suite", "describe", "unavailable_key"]


def _stem(out: Path) -> str:
    """Today's date, with -2, -3, ... if a run of today is already in ``out``."""
    stamp = _dt.datetime.now().strftime("%Y-%m-%d")
    stem, k = stamp, 2
    while (out / f"{stem}.json").exists():
        stem, k = f"{stamp}-{k}", k + 1
    return stem


def unavailable_key(input_name: str, mesher: str) -> str:
    """How ``record["unavailable"]`` names a mesher of an input."""
    return mesher if input_name == "implicit" else f"{mesher} ({input_name})"


def describe(case: dict, run: dict) -> str:
    """One line about one run, for the log."""
    head = f"{case['surface']:18s} {record.fmt_size(case['size']):>5s} {case['mesher']:20s} "
    head += f"rep {run['repeat']}: "
    if run["status"] != "ok":
        return head + f"{run['status'].upper()} {run['error']}"
    rss = run["peak_rss_mb"]
    return head + (
        f"{run['seconds']:8.2f} s {run['vertices']:9d} vertices "
        + (f"{rss:8.0f} MB" if rss is not None else "    ? MB")
    )


class Suite:
    """One suite run: the settings, the JSON record and where it goes."""

    def __init__(self, args: argparse.Namespace) -> None:
        self.args = args
        self.out = Path(args.out)
        self.tmp = self.out / "tmp"
        self.cache = self.tmp / "cache"
        self.cache.mkdir(parents=True, exist_ok=True)
        self.stem = _stem(self.out)
        self.json_path = self.out / f"{self.stem}.json"
        self.results: dict[str, Any] = record.new_record(args)
        self.unavailable: dict[str, str] = self.results["unavailable"]
        self.meshers: dict[str, Mesher] = {}
        # The other inputs' adapters, by (input, mesher).
        self.input_meshers: dict[tuple[str, str], Mesher] = {}
        self.quality = QualityMeter(
            self.cache, args.reference_samples, args.angle, args.seed, self.log
        )

    def log(self, msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    def save(self) -> None:
        record.save(self.results, self.json_path)

    def run(self) -> None:
        """Every input's cases, then ``finished`` is set."""
        if "implicit" in self.args.inputs:
            self.run_implicit()
        for name in self.args.inputs:
            if name != "implicit":
                self.run_input(name)
        self.results["finished"] = True

    def run_implicit(self) -> None:
        """The built-in surfaces: calibrate each, then every size and mesher."""
        args = self.args
        self.meshers = adapters(args.meshers, args, self.results, self.log)
        self.save()
        target = calibration_target(args.sizes)
        for surface in args.surfaces:
            cal = cached_calibration(
                self.cache, surface, args.angle, target, args.seed,
                recalibrate=args.recalibrate, log=self.log,
            )  # fmt: skip
            self.results["calibration"][surface] = cal
            self.save()
            for size in sorted(int(s) for s in args.sizes):
                cases = {
                    m: self.new_case(m, surface, size, self.meshers[m].params(surface, size, cal))
                    for m in args.meshers
                }
                self.run_cases(cases)

    def run_input(self, name: str) -> None:
        """One of the other inputs: every case, size and mesher of it."""
        args = self.args
        kind = inputs.kind(name)
        names = [m for m in kind.meshers if args.input_meshers is None or m in args.input_meshers]
        for m in names:
            adapter, why = kind.adapter(m, self.results, self.log)
            self.input_meshers[name, m] = adapter
            if why is not None:
                self.unavailable[unavailable_key(name, m)] = why
                self.log(f"note: {m} on the {name} input skipped: {why}")
        self.save()
        for case_name in kind.cases():
            if args.cases and case_name not in args.cases:
                continue
            for size in sorted(int(s) for s in args.sizes):
                params = kind.params(case_name, size)
                cases = {m: self.new_case(m, case_name, size, params, name) for m in names}
                self.run_cases(cases)

    def adapter(self, case: dict) -> Mesher:
        """The adapter that runs ``case``."""
        name = case.get("input", "implicit")
        if name == "implicit":
            return self.meshers[case["mesher"]]
        return self.input_meshers[name, case["mesher"]]

    def new_case(
        self, mesher: str, surface: str, size: int, params: dict, input_name: str = "implicit"
    ) -> dict[str, Any]:
        """A case, marked if it is not run, appended to the record."""
        case = record.new_case(surface, size, mesher, params, input_name)
        why = self.skip_reason(case)
        if why is not None:
            key = unavailable_key(input_name, mesher)
            case.update(status="unavailable" if key in self.unavailable else "skipped", note=why)
        self.results["cases"].append(case)
        return case

    def skip_reason(self, case: dict) -> str | None:
        mesher, surface, size = case["mesher"], case["surface"], case["size"]
        key = unavailable_key(case["input"], mesher)
        if key in self.unavailable:
            return self.unavailable[key]
        why = self.adapter(case).skip(size, self.args)
        if why is not None:
            return why
        # A mesher that failed or timed out on a smaller size is not tried again.
        for c in self.results["cases"]:
            if (
                c["mesher"] == mesher
                and c["surface"] == surface
                and c["size"] < size
                and c["status"] in ("failed", "timeout")
            ):
                return f"{c['status']} at size {record.fmt_size(c['size'])}"
        return None

    def points_path(self, surface: str, size: int) -> Path:
        """Where the floor finds rdmesh's vertices of a case."""
        return self.tmp / f"{surface}-{size}-rdmesh-vertices.xyz"

    def keep_points(self, cases: dict[str, dict], run: dict) -> None:
        """Write the vertices of rdmesh's mesh for the floor (once per case)."""
        floor = cases.get(FLOOR)
        if floor is None or floor["status"] in ("skipped", "unavailable"):
            return
        if floor.get("points_file") or run["status"] != "ok" or not run.get("mesh_file"):
            return
        from cgal_runner import write_points
        from meshfile import load_mesh
        from metrics import compact

        v, f = compact(*load_mesh(run["mesh_file"]))
        path = self.points_path(floor["surface"], floor["size"])
        write_points(path, v)
        floor["points_file"] = str(path)

    def run_cases(self, cases: dict[str, dict]) -> None:
        """The repeats of one surface and size, meshers alternating.

        The floor runs after rdmesh in the first repeat (it needs rdmesh's
        vertices); from then on the order alternates as for the others.
        """
        first = list(cases)
        if FLOOR in first and "rdmesh" in first:
            first.remove(FLOOR)
            first.insert(first.index("rdmesh") + 1, FLOOR)
        try:
            self._run_repeats(cases, first)
        finally:
            floor = cases.get(FLOOR)
            if floor is not None and floor.get("points_file"):
                Path(floor.pop("points_file")).unlink(missing_ok=True)
                self.save()

    def _run_repeats(self, cases: dict[str, dict], first: list[str]) -> None:
        args = self.args
        for rep in range(args.repeats):
            order = first if rep % 2 == 0 else list(reversed(first))
            for mesher in order:
                case = cases[mesher]
                if case["status"] in ("skipped", "unavailable"):
                    continue
                if rep >= self.adapter(case).repeats(args):
                    continue
                if any(r["status"] == "timeout" for r in case["runs"]):
                    continue  # do not spend another timeout on it
                keep = case["quality"] is None and self.adapter(case).writes_mesh
                run = self.run_once(case, rep, keep_mesh=keep)
                case["runs"].append(run)
                if mesher == "rdmesh":
                    self.keep_points(cases, run)
                self.log(describe(case, run))
                if run["status"] == "ok" and case["quality"] is None and "mesh_file" in run:
                    try:
                        case["quality"] = self.measure_quality(case, run["mesh_file"])
                    except Exception as exc:  # noqa: BLE001 - record, do not crash
                        case["quality"] = {"error": f"{type(exc).__name__}: {exc}"}
                if run.get("mesh_file"):
                    Path(run["mesh_file"]).unlink(missing_ok=True)
                    run.pop("mesh_file")
                record.summarise(case)
                self.save()

    def measure_quality(self, case: dict, mesh_file: str) -> dict[str, Any]:
        """The quality entry of a case, from the mesh its run wrote."""
        name = case.get("input", "implicit")
        if name == "implicit":
            bbox = self.results["calibration"][case["surface"]]["bbox"]
            return self.quality.measure(case["surface"], mesh_file, bbox)
        import time

        from meshfile import load_mesh
        from metrics import compact

        t0 = time.perf_counter()
        v, f = compact(*load_mesh(mesh_file))
        args = self.args
        q = inputs.kind(name).quality(
            case["surface"], case["params"], v, f,
            reference_samples=args.reference_samples, seed=args.seed, angle=args.angle,
        )  # fmt: skip
        q["seconds"] = time.perf_counter() - t0
        return q

    def run_once(self, case: dict, repeat: int, keep_mesh: bool) -> dict[str, Any]:
        """One run of a case in a fresh process: the run's record."""
        m = self.adapter(case)
        mesh_path = None
        if keep_mesh:
            stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", case["surface"])
            mesh_path = str(self.tmp / f"{stem}-{case['size']}-{m.name}{m.suffix}")
        timeout = m.timeout(self.args)
        load = os.getloadavg()[0]
        try:
            cmd = m.command(case, self.args, mesh_path)
        except ValueError as exc:
            return {"repeat": repeat, "status": "failed", "error": str(exc),
                    "process_seconds": 0.0, "peak_rss_mb": None, "loadavg": load}  # fmt: skip
        limit = self.args.memory_limit_gb * 1024 if self.args.memory_limit_gb else None
        res = run_measured(cmd, timeout, memory_limit_mb=limit)
        run: dict[str, Any] = {
            "repeat": repeat,
            "status": "ok",
            "error": None,
            "process_seconds": res["wall"],
            "peak_rss_mb": res["peak_rss_mb"],
            "loadavg": load,
        }
        if res["timed_out"]:
            run.update(status="timeout", error=f"killed after {timeout} s")
            return run
        try:
            child = m.parse(res, f"{m.name} on {case['surface']}", self.results["versions"])
        except (RuntimeError, ValueError) as exc:
            run.update(status="failed", error=str(exc).strip()[-2000:])
            return run
        run.update(child)
        run["vertices_per_second"] = (
            child["vertices"] / child["seconds"] if child["seconds"] > 0 else None
        )
        if mesh_path is not None:
            run["mesh_file"] = mesh_path
        return run

    def finish(self) -> dict[str, Path]:
        """Write the report and plots (and the final JSON); what was written where."""
        import plots
        import report

        self.results["machine"]["loadavg_end"] = list(os.getloadavg())
        self.results["targets"] = report.targets(self.results)
        self.save()
        files = plots.render_suite(self.results, self.out, self.stem)
        md = report.build(self.results, {k: p.name for k, p in files.items()})
        md_path = self.out / f"{self.stem}.md"
        md_path.write_text(md)
        return {"json": self.json_path, "report": md_path, **files}
