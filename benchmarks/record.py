# SPDX-License-Identifier: GPL-3.0-or-later
"""The suite's JSON record: its header, a case's summary, writing it.

The format is described in benchmarks/README.md ("The JSON").
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import math
import os
import platform
import statistics
import subprocess
import sys
from pathlib import Path
from typing import Any

__all__ = [
    "SCHEMA",
    "fmt_size",
    "jsonable",
    "machine_info",
    "new_case",
    "new_record",
    "package_versions",
    "save",
    "summarise",
]

SCHEMA = "rdmesh-benchmark-suite/1"
HERE = Path(__file__).resolve().parent


def fmt_size(n: float) -> str:
    """A vertex count as the tables show it: 1M, 10k, 500."""
    n = int(n)
    if n >= 1_000_000 and n % 1_000_000 == 0:
        return f"{n // 1_000_000}M"
    if n >= 1000 and n % 1000 == 0:
        return f"{n // 1000}k"
    return str(n)


def jsonable(obj):
    """``obj`` with numpy scalars as Python numbers and non-finite floats as None."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if hasattr(obj, "item") and callable(obj.item):  # numpy scalar
        return obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def save(results: dict[str, Any], path: Path) -> None:
    """Write ``results`` to ``path`` atomically (a ``.part`` file, then a rename)."""
    tmp = path.with_suffix(".json.part")
    tmp.write_text(json.dumps(jsonable(results), indent=1))
    tmp.replace(path)


# ---------------------------------------------------------------------------
# The header
# ---------------------------------------------------------------------------


def machine_info() -> dict[str, Any]:
    info: dict[str, Any] = {
        "platform": platform.platform(),
        "python": platform.python_version(),
        "cores": os.cpu_count(),
        "loadavg_start": list(os.getloadavg()),
    }
    try:
        for ln in Path("/proc/cpuinfo").read_text().splitlines():
            if ln.startswith("model name"):
                info["cpu"] = ln.split(":", 1)[1].strip()
                break
        for ln in Path("/proc/meminfo").read_text().splitlines():
            if ln.startswith("MemTotal"):
                info["memory_gb"] = round(int(ln.split()[1]) / 1024**2, 1)
                break
    except OSError:
        pass
    return info


def git_commit() -> str:
    """The short hash of this checkout's HEAD ("" outside a git checkout)."""
    try:
        rev = subprocess.run(
            ["git", "-C", str(HERE), "rev-parse", "--short", "HEAD"],
            capture_output=True, text=True, timeout=10, check=False,
        )  # fmt: skip
    except (OSError, subprocess.SubprocessError):
        return ""
    return rev.stdout.strip()


def package_versions() -> dict[str, Any]:
    from importlib import metadata

    out: dict[str, Any] = {}
    for name in ("rdmesh", "numpy", "scipy", "scikit-image", "matplotlib", "trimesh"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    try:
        import rdmesh

        out["rdmesh_cgal"] = getattr(rdmesh, "CGAL_VERSION", None)
    except ImportError:
        pass
    try:
        rev = subprocess.run(
            ["git", "-C", str(HERE), "describe", "--always", "--dirty"],
            capture_output=True,
            text=True,
            timeout=10,
            check=False,
        )
        out["git"] = rev.stdout.strip() or None
    except (OSError, subprocess.SubprocessError):
        out["git"] = None
    return out


def new_record(args: argparse.Namespace) -> dict[str, Any]:
    """The record of a suite run with these settings, before anything ran."""
    return {
        "schema": SCHEMA,
        "date": _dt.datetime.now().isoformat(timespec="seconds"),
        "command": [Path(sys.executable).name, *sys.argv],
        "machine": machine_info(),
        "versions": package_versions(),
        "settings": {
            "quick": args.quick,
            "inputs": list(getattr(args, "inputs", ["implicit"])),
            "cases": list(getattr(args, "cases", None) or []),
            "input_meshers": getattr(args, "input_meshers", None),
            "surfaces": list(args.surfaces),
            "sizes": [int(s) for s in args.sizes],
            "meshers": list(args.meshers),
            "repeats": args.repeats,
            "angle": args.angle,
            "distance_over_radius": 1.0,
            "seed": args.seed,
            "timeout": args.timeout,
            "cgal_error_bound": args.cgal_error_bound,
            "pygalmesh_max_size": int(args.pygalmesh_max_size),
            "pygalmesh_repeats": args.pygalmesh_repeats,
            "pygalmesh_timeout": args.pygalmesh_timeout or args.timeout,
            "memory_limit_gb": args.memory_limit_gb,
            "pygalmesh_error_bound": 1e-3,
            "reference_samples": args.reference_samples,
        },
        "unavailable": {},
        "calibration": {},
        "cases": [],
        "targets": [],
        "finished": False,
    }


# ---------------------------------------------------------------------------
# Cases
# ---------------------------------------------------------------------------


def new_case(
    surface: str, size: int, mesher: str, params: dict[str, Any], input_name: str = "implicit"
) -> dict[str, Any]:
    """A case (one mesher, surface and size) before its first run.

    ``input_name``: "implicit" (a built-in surface) or one of the other
    inputs (``inputs.INPUTS``), whose case name is ``surface``.
    """
    return {
        "input": input_name,
        "surface": surface,
        "size": size,
        "mesher": mesher,
        "params": params,
        "status": "pending",
        "note": None,
        "runs": [],
        "summary": None,
        "quality": None,
    }


def summarise(case: dict) -> None:
    """Set the case's ``status`` and ``summary`` (medians) from its runs."""
    ok = [r for r in case["runs"] if r["status"] == "ok"]
    if not ok:
        case["status"] = case["runs"][-1]["status"] if case["runs"] else case["status"]
        case["summary"] = None
        return
    case["status"] = "ok"
    secs = [r["seconds"] for r in ok]
    med = statistics.median(secs)
    nv = ok[0]["vertices"]
    case["summary"] = {
        "n_ok": len(ok),
        "n_runs": len(case["runs"]),
        "seconds": med,
        "seconds_all": secs,
        "process_seconds": statistics.median(r["process_seconds"] for r in ok),
        "vertices": nv,
        "faces": ok[0]["faces"],
        "vertices_per_second": nv / med if med > 0 else None,
        "peak_rss_mb": (
            statistics.median(rss)
            if (rss := [r["peak_rss_mb"] for r in ok if r["peak_rss_mb"] is not None])
            else None
        ),
        "evaluations": ok[0]["evaluations"],
        "evaluations_per_vertex": ok[0]["evaluations"] / nv if nv else None,
        "deterministic": len({(r["vertices"], r["faces"]) for r in ok}) == 1,
    }
