# SPDX-License-Identifier: GPL-3.0-or-later
"""Markdown report of a benchmark-suite result.

``build(results, plots)`` returns the whole report; ``tables(results)`` only
the headline, time-ratio, performance, quality and target tables (what
``suite.py`` prints); ``targets(results)`` evaluates the issue's performance
targets.

Every ratio names what it divides by: "Mesh_3 (no manifold)" is
``make_mesh_3`` without ``params::manifold()`` (``cgal_mesh_3_fast``),
"Mesh_3 (manifold)" with it (``cgal_mesh_3``), "floor" CGAL's bulk
``Delaunay_triangulation_3`` of rdmesh's own vertices of the same case
(``cgal_delaunay_floor``).  The headline divides rdmesh's time by the faster
of the two Mesh_3 settings.

Regenerate the report and plots of an earlier run from its JSON::

    python benchmarks/report.py benchmarks/results/2025-01-31.json
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

__all__ = ["LABELS", "build", "implicit", "tables", "targets"]

#: Peak memory every 1M-vertex run must stay within (the machine's size).
MEMORY_LIMIT_MB = 24 * 1024
TARGET_MIN_SIZE = 100_000
BIG_SIZE = 1_000_000
#: The issue's targets: rdmesh time <= TIME_TARGET x Mesh_3 (no manifold),
#: rdmesh time <= FLOOR_TARGET x the floor.
TIME_TARGET = 0.5
FLOOR_TARGET = 3.0

FLOOR = "cgal_delaunay_floor"
#: rdmesh's runs of the built-in surfaces: with f alone (gradients by central
#: differences, as most users write it; the issue's target) and with the exact
#: gradient ("rdmesh").
RDMESH_RUNS = ("rdmesh_f_only", "rdmesh")
#: The two Mesh_3 settings, the one the targets name first.
MESH_3_SETTINGS = ("cgal_mesh_3_fast", "cgal_mesh_3")
#: What each mesher is, as ratios and targets name it.
LABELS = {
    "rdmesh": "rdmesh",
    "rdmesh_f_only": "rdmesh (f only)",
    "rdmesh_certified": "rdmesh (certified)",
    "cgal_surface_mesher": "Surface_mesher",
    "cgal_mesh_3": "Mesh_3 (manifold)",
    "cgal_mesh_3_fast": "Mesh_3 (no manifold)",
    "pygalmesh": "pygalmesh",
    "marching_cubes": "marching cubes",
    FLOOR: "floor",
}


def _f(x, digits: int = 3) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        return f"{x:,}"
    if x == 0:
        return "0"
    if abs(x) >= 1000:
        return f"{x:,.0f}"
    return f"{x:.{digits}g}"


def _e(x) -> str:
    return "–" if x is None else f"{x:.2e}"


def _size(n: int) -> str:
    if n >= 1_000_000 and n % 1_000_000 == 0:
        return f"{n // 1_000_000}M"
    if n >= 1000 and n % 1000 == 0:
        return f"{n // 1000}k"
    return str(n)


def _table(header: list[str], rows: list[list[str]]) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join(" --- " for _ in header) + "|"]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(out)


def _status(c: dict) -> str:
    s = c.get("status", "?")
    if s == "ok":
        summ = c.get("summary") or {}
        n, total = summ.get("n_ok", 0), summ.get("n_runs", 0)
        return "ok" if n == total else f"ok ({n}/{total})"
    note = c.get("note")
    if not note:
        errs = [r.get("error") for r in c.get("runs", []) if r.get("error")]
        note = errs[-1] if errs else None
    if note:
        note = note.replace("|", "/").replace("\n", " ")
        if len(note) > 90:
            note = note[:87] + "..."
        return f"{s}: {note}"
    return s


def implicit(results: dict) -> dict[str, Any]:
    """``results`` with only the built-in surfaces' cases (not the other inputs')."""
    cases = [c for c in results.get("cases", []) if c.get("input", "implicit") == "implicit"]
    return {**results, "cases": cases}


def _find(results: dict, surface: str, size: int, mesher: str) -> dict | None:
    for c in results.get("cases", []):
        if c["surface"] == surface and c["size"] == size and c["mesher"] == mesher:
            return c
    return None


# ---------------------------------------------------------------------------
# Tables
# ---------------------------------------------------------------------------


def performance_table(results: dict) -> str:
    header = ["surface", "size", "mesher", "status", "vertices", "faces", "time (s)",
              "vertices/s", "peak RSS (MB)", "evaluations", "eval./vertex"]  # fmt: skip
    rows = []
    for c in results.get("cases", []):
        s = c.get("summary") or {}
        n = s.get("n_ok", 0)
        t = _f(s.get("seconds"))
        if n > 1:
            t += f" (med. {n})"
        rows.append([
            c["surface"], _size(c["size"]), c["mesher"], _status(c),
            _f(s.get("vertices")), _f(s.get("faces")), t if s else "–",
            _f(s.get("vertices_per_second")), _f(s.get("peak_rss_mb")),
            _f(s.get("evaluations")), _f(s.get("evaluations_per_vertex")),
        ])  # fmt: skip
    return _table(header, rows)


def _ok_summary(results: dict, surface: str, size: int, mesher: str) -> dict | None:
    c = _find(results, surface, size, mesher)
    return c.get("summary") if c and c.get("status") == "ok" else None


def _keys(results: dict) -> list[tuple[str, int]]:
    seen = [(c["surface"], c["size"]) for c in results.get("cases", [])]
    return list(dict.fromkeys(seen))


def headline(results: dict) -> list[dict[str, Any]]:
    """Per surface, size and rdmesh run (``mesher``, ``rdmesh_label``) with a
    Mesh_3 run: rdmesh's time over the faster Mesh_3 setting's (``ratio``),
    which setting that was (``setting``, ``label``) and both times."""
    out = []
    for surface, size in _keys(results):
        runs = [(m, s) for m in MESH_3_SETTINGS if (s := _ok_summary(results, surface, size, m))]
        if not runs:
            continue
        m, s = min(runs, key=lambda ms: ms[1]["seconds"])
        for v in RDMESH_RUNS:
            rd = _ok_summary(results, surface, size, v)
            if not rd:
                continue
            out.append({"surface": surface, "size": size, "mesher": v,
                        "rdmesh_label": LABELS[v], "setting": m, "label": LABELS[m],
                        "rdmesh_seconds": rd["seconds"], "mesh_3_seconds": s["seconds"],
                        "ratio": rd["seconds"] / s["seconds"]})  # fmt: skip
    return out


def headline_text(results: dict) -> str:
    rows = headline(results)
    if not rows:
        return "_No case with both rdmesh and a Mesh_3 setting._"
    lines = [
        "rdmesh's time ÷ the faster Mesh_3 setting's time of the same case (median of "
        "the repeats; the setting is named). Target (issue 14): <= "
        f"{TIME_TARGET} x Mesh_3 (no manifold) from 100k vertices on, with f alone. "
        "rdmesh (f only) gets the built-in surface's f alone (gradients by central "
        "differences); rdmesh gets its exact gradient too.",
        "",
    ]
    for h in rows:
        lines.append(
            f"- {h['surface']} {_size(h['size'])}: {h['rdmesh_label']} "
            f"{h['rdmesh_seconds']:.3g} s ÷ {h['label']} {h['mesh_3_seconds']:.3g} s = "
            f"**{h['ratio']:.3g}x**"
        )
    return "\n".join(lines)


def ratio_table(results: dict) -> str:
    """Times of rdmesh's runs and its references side by side, and rdmesh's time ÷ each."""
    refs = [m for m in ("cgal_mesh_3_fast", "cgal_mesh_3", "cgal_surface_mesher",
                        "marching_cubes", FLOOR)
            if any(c["mesher"] == m for c in results.get("cases", []))]  # fmt: skip
    header = ["surface", "size", "run", "rdmesh (s)"] + [f"{LABELS[m]} (s)" for m in refs]
    header += [f"rdmesh ÷ {LABELS[m]}" for m in refs]
    rows = []
    for surface, size in _keys(results):
        sums = [_ok_summary(results, surface, size, m) for m in refs]
        runs = [v for v in RDMESH_RUNS if _find(results, surface, size, v)]
        for v in runs or ([RDMESH_RUNS[-1]] if any(sums) else []):
            rd = _ok_summary(results, surface, size, v)
            row = [surface, _size(size), LABELS[v], _f(rd["seconds"]) if rd else "–"]
            row += [_f(s["seconds"]) if s else "–" for s in sums]
            row += [f"{rd['seconds'] / s['seconds']:.3g}x" if (rd and s and s["seconds"] > 0)
                    else "–" for s in sums]  # fmt: skip
            rows.append(row)
    if not rows:
        return "_No successful runs._"
    return _table(header, rows)


def quality_table(results: dict) -> str:
    header = ["surface", "size", "mesher", "min angle", "angles < 30°", "closed manifold",
              "components (exp.)", "Euler (exp.)", "topology", "Hausdorff", "H / r",
              "mesh→surface", "surface→mesh", "vertex offset"]  # fmt: skip
    rows = []
    for c in results.get("cases", []):
        q = c.get("quality")
        if c.get("status") != "ok" or not q:
            continue
        if "error" in q:
            err = f"metrics failed: {q['error']}"
            rows.append([c["surface"], _size(c["size"]), c["mesher"], err]
                        + ["–"] * (len(header) - 4))  # fmt: skip
            continue
        t = q.get("topology") or {}
        h = q.get("hausdorff") or {}
        r = (c.get("params") or {}).get("radius")
        two = h.get("two_sided")
        frac = q.get("frac_angles_below_30")
        ok = t.get("topology_ok")
        rows.append([
            c["surface"], _size(c["size"]), c["mesher"],
            _f(q.get("min_angle"), 4) + "°" if q.get("min_angle") is not None else "–",
            f"{100 * frac:.3g} %" if frac is not None else "–",
            _f(t.get("closed_manifold")),
            f"{t.get('components')} ({t.get('expected_components')})",
            f"{t.get('euler')} ({t.get('expected_euler')})",
            "ok" if ok else ("WRONG" if ok is False else "–"),
            _e(two), _f(two / r, 2) if (two is not None and r) else "–",
            _e((h.get("mesh_to_surface") or {}).get("max")),
            _e((h.get("surface_to_mesh") or {}).get("max")),
            _e(h.get("vertex_to_surface_max")),
        ])  # fmt: skip
    return _table(header, rows)


def targets(results: dict) -> list[dict[str, Any]]:
    """The issue's targets at every measured size >= 100k, as a list of checks.

    Each check: ``surface``, ``size``, ``target``, ``value`` (a ratio or MB),
    ``passed`` (True/False, None when a needed run is missing) and ``note``.
    """
    out: list[dict[str, Any]] = []
    results = implicit(results)
    cases = results["cases"]
    keys = sorted({(c["surface"], c["size"]) for c in cases}, key=lambda k: (k[1], k[0]))
    for surface, size in keys:
        if size < TARGET_MIN_SIZE:
            continue
        pg = _find(results, surface, size, "pygalmesh")
        fl = _find(results, surface, size, FLOOR)

        def summ(c):
            return c.get("summary") if c and c.get("status") == "ok" else None

        spg, sfl = summ(pg), summ(fl)

        def check(target, value, passed, note=None, unit="x", surface=surface, size=size):
            out.append({"surface": surface, "size": size, "target": target, "value": value,
                        "unit": unit, "passed": passed, "note": note})  # fmt: skip

        # Time and memory of each rdmesh run against each Mesh_3 setting that
        # was run (the target: f alone, Mesh_3 without manifold()).
        settings = [m for m in MESH_3_SETTINGS if _find(results, surface, size, m)]
        runs = [v for v in RDMESH_RUNS if _find(results, surface, size, v)] or ["rdmesh"]
        for v, m in ((v, m) for v in runs for m in settings or [MESH_3_SETTINGS[0]]):
            label, who = LABELS[m], LABELS[v]
            srd = summ(_find(results, surface, size, v))
            sm3 = summ(_find(results, surface, size, m))
            t_time = f"{who} time <= {TIME_TARGET} x {label}"
            t_mem = f"{who} peak RSS <= {label}"
            if srd and sm3:
                ratio = srd["seconds"] / sm3["seconds"]
                check(t_time, ratio, ratio <= TIME_TARGET,
                      f"{srd['seconds']:.3g} s vs {sm3['seconds']:.3g} s; "
                      f"{srd['vertices']:,} vs {sm3['vertices']:,} vertices")  # fmt: skip
                if srd.get("peak_rss_mb") and sm3.get("peak_rss_mb"):
                    mem = srd["peak_rss_mb"] / sm3["peak_rss_mb"]
                    check(t_mem, mem, mem <= 1.0,
                          f"{srd['peak_rss_mb']:.0f} vs {sm3['peak_rss_mb']:.0f} MB")  # fmt: skip
                else:
                    check(t_mem, None, None, "peak RSS not measured")
            else:
                why = who if not srd else label
                check(t_time, None, None, f"no successful {why} run")
                check(t_mem, None, None, f"no successful {why} run")
        srd = summ(_find(results, surface, size, "rdmesh"))
        t_floor = f"rdmesh time <= {FLOOR_TARGET:g} x floor"
        if srd and sfl:
            ratio = srd["seconds"] / sfl["seconds"]
            note = (
                f"{srd['seconds']:.3g} s vs {sfl['seconds']:.3g} s "
                f"(Delaunay_triangulation_3 of rdmesh's {sfl['vertices']:,} vertices)"
            )
            check(t_floor, ratio, ratio <= FLOOR_TARGET, note)
        elif fl is not None:
            check(t_floor, None, None, _status(fl))
        if srd and spg:
            speed = spg["seconds"] / srd["seconds"]
            check("rdmesh >= 100 x faster than pygalmesh", speed, speed >= 100,
                  f"{spg['seconds']:.1f} s vs {srd['seconds']:.1f} s")  # fmt: skip
        else:
            note = (pg or {}).get("note") or ("no successful run" if pg else "not run")
            if pg and pg.get("status") == "timeout" and srd:
                # A timeout still bounds the speed-up from below.
                st = results.get("settings") or {}
                lim = st.get("pygalmesh_timeout") or st.get("timeout")
                note = (
                    f"pygalmesh timed out; speed-up > {lim / srd['seconds']:.0f}" if lim else note
                )
            check("rdmesh >= 100 x faster than pygalmesh", None, None, note)
        if size >= BIG_SIZE:
            rds = (_find(results, surface, size, v) for v in RDMESH_RUNS)
            for c in (*rds, *(_find(results, surface, size, m) for m in MESH_3_SETTINGS),
                      _find(results, surface, size, "cgal_surface_mesher")):  # fmt: skip
                if c is None:
                    continue
                s = summ(c)
                target = f"{c['mesher']} completes 1M within 24 GB"
                if s and s.get("peak_rss_mb") is not None:
                    check(target, s["peak_rss_mb"], s["peak_rss_mb"] <= MEMORY_LIMIT_MB,
                          None, "MB")  # fmt: skip
                else:
                    check(target, None, False if c.get("status") in ("failed", "timeout")
                          else None, _status(c), "MB")  # fmt: skip
    return out


def targets_table(results: dict) -> str:
    checks = results.get("targets") or targets(results)
    if not checks:
        return "_No size >= 100k was run; the targets apply from 100k vertices on._"
    rows = []
    for t in checks:
        v = t["value"]
        if v is None:
            val = "–"
        elif t.get("unit") == "MB":
            val = f"{v:,.0f} MB"
        else:
            val = f"{v:.3g}x"
        res = {True: "**pass**", False: "**FAIL**", None: "not measured"}[t["passed"]]
        rows.append([t["surface"], _size(t["size"]), t["target"], val, res, t.get("note") or ""])
    return _table(["surface", "size", "target", "measured", "result", "note"], rows)


def tables(results: dict) -> str:
    """Headline, time ratios, performance, quality and targets tables, as markdown,
    of the built-in surfaces; then a table per other input (``report_inputs``)."""
    import report_inputs

    other = report_inputs.tables(results)
    results = implicit(results)
    if other and not results["cases"]:
        return other
    return "\n\n".join([
        "### Headline: rdmesh ÷ the faster Mesh_3 setting", headline_text(results),
        "### Time ratios (rdmesh ÷ each reference, same case, medians)",
        ratio_table(results),
        "### Performance", performance_table(results),
        "### Quality", quality_table(results),
        "### Targets (sizes >= 100k)", targets_table(results),
    ] + ([other] if other else []))  # fmt: skip


# ---------------------------------------------------------------------------
# The whole report
# ---------------------------------------------------------------------------


def _setup(results: dict) -> str:
    s = results.get("settings", {})
    m = results.get("machine", {})
    v = results.get("versions", {})
    lines = [
        f"- date: {results.get('date')}; total time {_f(results.get('seconds'))} s"
        + ("" if results.get("finished") else " (**interrupted: partial results**)"),
        f"- machine: {m.get('cpu', '?')}, {m.get('cores')} cores, {m.get('memory_gb')} GB; "
        f"{m.get('platform')}; load average at start "
        f"{', '.join(f'{x:.2f}' for x in m.get('loadavg_start', []))}",
        "- versions: " + ", ".join(f"{k} {val}" for k, val in v.items() if val),
        f"- command: `{' '.join(results.get('command', []))}`",
        f"- inputs: {', '.join(s.get('inputs', ['implicit']))}",
        f"- criteria: angle {s.get('angle')}°, radius bound r from calibration, "
        f"distance bound = r, seed {s.get('seed')}",
        f"- repeats: {s.get('repeats')} (pygalmesh: {s.get('pygalmesh_repeats')}, sizes up to "
        f"{_size(s.get('pygalmesh_max_size', 0))}); meshers alternate run by run, the median "
        f"time is reported; timeout {s.get('timeout')} s per run",
        f"- CGAL oracle error bound {s.get('cgal_error_bound')} (relative to the bounding "
        f"sphere); pygalmesh uses CGAL's default 1e-3 and `Non_manifold_tag`",
        f"- Hausdorff reference: {s.get('reference_samples'):,} points on each surface"
        if s.get("reference_samples")
        else "",
    ]
    for mesher, why in (results.get("unavailable") or {}).items():
        lines.append(f"- **{mesher} not run**: {why}")
    return "\n".join(ln for ln in lines if ln)


def _calibration(results: dict) -> str:
    rows = []
    cal = results.get("calibration", {})
    sizes = sorted({c["size"] for c in results.get("cases", [])})
    for surface, c in cal.items():
        radii = ", ".join(f"{_size(n)}: {math.sqrt(c['C'] * c['area'] / n):.4g}" for n in sizes)
        rows.append([surface, _f(c["area"]), _f(c["vertices"]), _f(c["radius"], 4),
                     _f(c["C"]), radii])  # fmt: skip
    return _table(["surface", "area", "calibration vertices", "at radius", "C = V r² / A",
                   "radius bound per size"], rows)  # fmt: skip


_METHOD = """\
- **Time** is the wall time of the meshing call inside its process: rdmesh's
  `mesh_surface`, CGAL's `make_surface_mesh` / `make_mesh_3` (timed by the
  reference program), pygalmesh's `generate_surface_mesh` (including its OFF
  round trip), and for marching cubes the evaluation of f on the grid plus
  `marching_cubes`.  Process start and imports are not included.
- **Mesh_3 settings**: `cgal_mesh_3` is `make_mesh_3` with
  `params::manifold()` ("Mesh_3 (manifold)"), `cgal_mesh_3_fast` the same
  call without it ("Mesh_3 (no manifold)"); both facet criteria only, no
  perturb/exude, sequential.  The headline divides rdmesh's time by the
  faster of the two.
- **The floor** (`cgal_delaunay_floor`): CGAL's bulk
  `Delaunay_triangulation_3(begin, end)` (spatial sort + insertion, EPICK) of
  the vertices of rdmesh's first run of the same case, read from a text file
  by the reference program and timed around the constructor alone.  Any
  method whose output is the restricted Delaunay triangulation of those
  vertices builds at least this; "rdmesh ÷ floor" is how far above it rdmesh
  is.  It has no surface, so no quality row.
- **Marching cubes** at the same target vertex count is a reference row: the
  cost of sampling f on a grid and extracting a surface, without refinement
  or guarantees.
- **Peak RSS** is the maximum resident set size of the whole child process
  (`wait4`), so the Python meshers include the interpreter and numpy/scipy
  (about 100 MB).
- **Evaluations**: points at which f was evaluated (rdmesh: its counter,
  gradients included; CGAL and pygalmesh: calls of the function; marching
  cubes: grid points).
- **Angles**: the three angles of every triangle; "min angle" is the smallest,
  "angles < 30°" the share of all angles below 30°.
- **Topology**: closed manifold (every edge in two triangles, one fan per
  vertex), connected components and Euler characteristic V - E + F against
  the surface's (sphere 2, torus 0, double torus -2, tanglecube -8, two
  spheres 2 + 2).
- **Hausdorff**: mesh→surface from vertices, face centroids and F random
  area-weighted points, each projected on f = 0 by Newton along its gradient
  line; surface→mesh from reference points (a fine marching-cubes mesh
  projected on f = 0) to the nearest of 16 candidate triangles, exactly.
  "H / r" divides the two-sided value by the radius bound; "vertex offset" is
  how far the vertices themselves are from f = 0 (oracle accuracy).
  See `benchmarks/metrics.py`.
"""


def build(results: dict, plots: dict[str, str] | None = None) -> str:
    """The full markdown report; ``plots`` maps plot names to file names."""
    import report_inputs

    plots = plots or {}
    parts = ["# rdmesh benchmark suite", _setup(results)]
    others = report_inputs.sections(results, plots)
    results = implicit(results)
    if not results["cases"] and others:
        return "\n\n".join([*parts, *others, "## How it is measured", _METHOD]) + "\n"
    parts += [
        "## Calibration",
        "Target vertex counts map to a radius bound through vertices ≈ C · area / r², "
        "with C from an rdmesh run on each surface. CGAL and pygalmesh get the same r; "
        "marching cubes a grid spacing h = sqrt(1.5 · area / N).",
        _calibration(results),
        tables(results).replace("### ", "## "),
    ]
    titles = {
        "time": "Time against vertices",
        "memory": "Peak memory against vertices",
        "hausdorff": "Hausdorff distance against vertices",
        "angles": "Smallest-angle histograms",
    }
    own = {k: v for k, v in plots.items() if k in titles}
    if own:
        parts.append("## Plots")
        for key, name in own.items():
            parts.append(f"### {titles.get(key, key)}\n\n![{key}]({name})")
    parts += [*others, "## How it is measured", _METHOD]
    return "\n\n".join(parts) + "\n"


def main(argv: list[str] | None = None) -> int:
    import json

    p = argparse.ArgumentParser(description="Rebuild the report and plots of a suite run.")
    p.add_argument("results", type=Path, help="a JSON file written by suite.py")
    args = p.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import plots as plotting

    results = json.loads(args.results.read_text())
    results["targets"] = targets(results)
    stem = args.results.stem
    files = plotting.render_suite(results, args.results.parent, stem)
    md = build(results, {k: p.name for k, p in files.items()})
    out = args.results.with_suffix(".md")
    out.write_text(md)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
