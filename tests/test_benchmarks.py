"""The benchmark suite (benchmarks/suite.py): --quick runs end to end, and its parts.

The suite itself is not part of the package; these tests keep it from rotting.
They need the benchmark dependencies (benchmarks/requirements.txt) and are
skipped without scikit-image.

The default run covers a tiny suite (rdmesh and marching cubes on the sphere,
about 15 s).  The ``slow`` ones (``pytest -m slow``) run every mesher on two
surfaces and the CGAL reference's failure path: the CGAL meshers run when the
reference program builds (cmake + CGAL headers; the first build takes about a
minute), and pygalmesh when it is importable; otherwise the suite records
them as unavailable, which is checked too.
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("skimage")
pytest.importorskip("matplotlib")

from rdmesh.surfaces import SURFACES, get  # noqa: E402

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))

import measure  # noqa: E402
import meshers  # noqa: E402
import meshfile  # noqa: E402
import metrics  # noqa: E402
import record  # noqa: E402
import suite  # noqa: E402

QUICK_SIZE = 1000
#: The --quick runs checked below: "tiny" (rdmesh and marching cubes on the
#: sphere, about 15 s) is the default run's end-to-end test; "full" (every
#: mesher on two surfaces; builds the CGAL reference if needed) is slow.
RUNS = {
    "tiny": ["--surfaces", "sphere", "--sizes", "500", "--meshers", "rdmesh", "marching_cubes"],
    "full": ["--surfaces", "sphere", "torus", "--sizes", str(QUICK_SIZE)],
}
STATUSES = {"ok", "failed", "timeout", "skipped", "unavailable"}
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _run_suite(out: Path, *extra: str, timeout: float = 600) -> subprocess.CompletedProcess:
    cmd = [sys.executable, str(BENCH / "suite.py"), "--out", str(out), *extra]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, check=False)


def _results(out: Path) -> dict:
    files = sorted(out.glob("*.json"))
    assert len(files) == 1, files
    return json.loads(files[0].read_text())


@dataclass
class QuickRun:
    out: Path
    proc: subprocess.CompletedProcess
    res: dict  # the JSON record
    surfaces: list[str]
    meshers: list[str]
    size: int


@pytest.fixture(
    scope="module",
    params=[pytest.param("tiny"), pytest.param("full", marks=pytest.mark.slow)],
)
def quick(request, tmp_path_factory) -> QuickRun:
    extra = RUNS[request.param]
    out = tmp_path_factory.mktemp(f"bench-{request.param}")
    proc = _run_suite(out, "--quick", *extra)
    assert proc.returncode == 0, proc.stderr[-4000:]
    args = suite.parse_args(["--quick", *extra])
    return QuickRun(out, proc, _results(out), args.surfaces, args.meshers, args.sizes[0])


def test_total_time_covers_every_run(quick):
    # The runs are sequential child processes inside the suite's own run.
    res = quick.res
    runs = [r for c in res["cases"] for r in c["runs"]]
    assert runs
    measured = res.get("cgal_build_seconds", 0.0) + sum(r["process_seconds"] for r in runs)
    assert res["seconds"] >= measured > 0


def test_json_schema(quick):
    res, surfaces, names, size = quick.res, quick.surfaces, quick.meshers, quick.size
    assert res["schema"] == record.SCHEMA
    assert res["finished"] is True
    for key in ("date", "command", "machine", "versions", "settings", "calibration",
                "cases", "targets", "unavailable"):  # fmt: skip
        assert key in res, key
    s = res["settings"]
    assert s["quick"] is True and s["repeats"] == 1
    assert s["sizes"] == [size] and s["surfaces"] == list(surfaces)
    assert s["meshers"] == list(names)
    assert set(res["calibration"]) == set(surfaces)
    for cal in res["calibration"].values():
        assert cal["C"] > 0 and cal["area"] > 0 and cal["radius"] > 0

    cases = res["cases"]
    assert len(cases) == len(surfaces) * len(names)
    assert {(c["surface"], c["mesher"]) for c in cases} == {
        (s, m) for s in surfaces for m in names
    }
    for c in cases:
        assert c["status"] in STATUSES, c
        assert c["size"] == size
        if c["mesher"] in res["unavailable"]:
            assert c["status"] == "unavailable" and c["note"]
            continue
        # Everything that is installed must work on these easy surfaces.
        assert c["status"] == "ok", c
        (run,) = c["runs"]
        assert run["status"] == "ok" and run["error"] is None
        summ = c["summary"]
        if c["mesher"] == meshers.FLOOR:
            # The floor triangulates exactly rdmesh's vertices; no surface.
            (rd,) = [d for d in cases if d["surface"] == c["surface"] and d["mesher"] == "rdmesh"]
            assert summ["vertices"] == rd["summary"]["vertices"]
            assert run["extra"]["points"] == summ["vertices"] and run["extra"]["cells"] > 0
            assert summ["seconds"] > 0 and c["quality"] is None and "points_file" not in c
            continue
        for key in ("seconds", "vertices", "faces", "vertices_per_second", "peak_rss_mb",
                    "evaluations", "process_seconds"):  # fmt: skip
            assert summ[key] > 0, (c["mesher"], key)
        assert summ["process_seconds"] >= summ["seconds"]
        # Calibration maps the target to about that many vertices.
        assert 0.5 * size < summ["vertices"] < 2 * size, (c["mesher"], summ)
        q = c["quality"]
        assert q["vertices"] == summ["vertices"] and q["faces"] == summ["faces"]
        assert sum(q["min_angle_hist"]) == q["faces"]
        assert 0 <= q["frac_angles_below_30"] <= 1
        # A mesh is near its surface: within the distance bound r for the
        # Delaunay meshers, within a grid cell's diagonal for marching cubes;
        # and not exactly on it.
        h = q["hausdorff"]
        p = c["params"]
        bound = p["radius"] if "radius" in p else math.sqrt(3) * p["spacing"]
        for side in ("mesh_to_surface", "surface_to_mesh"):
            assert 0 < h[side]["max"] < bound, (c["mesher"], side, h[side], bound)
        assert h["surface_samples"] >= 0.5 * s["reference_samples"]


def test_rdmesh_topology_matches_expected(quick):
    res = quick.res
    for name in quick.surfaces:
        (c,) = [c for c in res["cases"] if c["surface"] == name and c["mesher"] == "rdmesh"]
        t = c["quality"]["topology"]
        assert t["closed_manifold"] is True
        assert t["components"] == SURFACES[name].components
        assert t["euler"] == SURFACES[name].euler
        assert t["topology_ok"] is True
        assert c["quality"]["min_angle"] >= 30.0 - 1e-9


def test_sphere_hausdorff_is_the_sagitta(quick):
    """On the unit sphere the distance is the sag of the largest facets.

    A facet whose surface Delaunay ball has radius <= r lies within
    1 - sqrt(1 - r^2) of the sphere; refinement drives facets close to r.
    """
    for c in quick.res["cases"]:
        if c["surface"] != "sphere" or c["mesher"] not in ("rdmesh", "cgal_mesh_3"):
            continue
        if c["status"] != "ok":
            continue
        r = c["params"]["radius"]
        sag = 1 - math.sqrt(1 - r * r)
        h = c["quality"]["hausdorff"]
        assert 0.5 * sag < h["mesh_to_surface"]["max"] <= 1.05 * sag
        assert 0.5 * sag < h["surface_to_mesh"]["max"] <= 1.05 * sag
        assert h["vertex_to_surface_max"] < 1e-5


def test_report_and_plots(quick):
    out, proc, res = quick.out, quick.proc, quick.res
    stem = sorted(out.glob("*.json"))[0].stem
    md = (out / f"{stem}.md").read_text()
    for heading in ("## Performance", "## Quality", "## Targets", "## Plots"):
        assert heading in md
    for c in res["cases"]:
        assert f"| {c['surface']} | {record.fmt_size(quick.size)} | {c['mesher']} |" in md
    assert "## Time ratios" in md and "rdmesh ÷ marching cubes" in md
    if any(c["mesher"] == "cgal_mesh_3_fast" and c["status"] == "ok" for c in res["cases"]):
        assert "rdmesh ÷ Mesh_3 (no manifold)" in md and "rdmesh ÷ Mesh_3 (manifold)" in md
    if any(c["mesher"] == meshers.FLOOR and c["status"] == "ok" for c in res["cases"]):
        assert "rdmesh ÷ floor" in md
    for why in res["unavailable"].values():
        assert why.split(" (")[0] in md
    for name in ("time", "memory", "hausdorff", "angles"):
        png = out / f"{stem}-{name}.png"
        assert f"]({png.name})" in md
        data = png.read_bytes()
        assert data[:8] == PNG_MAGIC
        import matplotlib.image

        img = matplotlib.image.imread(png)
        assert img.shape[0] > 200 and img.shape[1] > 300
        assert float(np.std(img[..., :3])) > 0.01  # not a blank canvas
    # The suite prints the tables and where it wrote everything.
    assert "| surface | size | mesher | status |" in proc.stdout
    assert str(out / f"{stem}.md") in proc.stdout


def test_timeouts_are_recorded_and_larger_sizes_skipped(tmp_path):
    proc = _run_suite(
        tmp_path, "--quick", "--surfaces", "sphere", "--sizes", "500", "1000",
        "--meshers", "rdmesh", "--timeout", "0.01", "--reference-samples", "2000",
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-4000:]
    res = _results(tmp_path)
    small, big = sorted(res["cases"], key=lambda c: c["size"])
    assert small["status"] == "timeout"
    assert small["runs"][0]["error"].startswith("killed after")
    assert big["status"] == "skipped" and "timeout at size 500" in big["note"]
    assert "timeout" in (tmp_path / f"{sorted(tmp_path.glob('*.json'))[0].stem}.md").read_text()


@pytest.mark.slow  # builds the CGAL reference on a fresh machine (a minute or two)
def test_failures_are_recorded(tmp_path):
    # The reference program rejects an error bound >= 1 (exit code 2).
    proc = _run_suite(
        tmp_path, "--quick", "--surfaces", "sphere", "--sizes", "500",
        "--meshers", "cgal_mesh_3", "--cgal-error-bound", "2", "--reference-samples", "2000",
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-4000:]
    (case,) = _results(tmp_path)["cases"]
    if case["status"] == "unavailable":
        pytest.skip(f"CGAL reference not available: {case['note']}")
    assert case["status"] == "failed"
    assert "error-bound" in case["runs"][0]["error"]


# ---------------------------------------------------------------------------
# The command line, the adapters and the record
# ---------------------------------------------------------------------------


def test_command_line_defaults_and_overrides():
    full = suite.parse_args([])
    assert full.sizes == [10_000, 100_000, 1_000_000] and full.repeats == 3
    assert full.surfaces == list(SURFACES) and full.meshers == list(meshers.MESHERS)
    assert full.timeout == 3600 and full.pygalmesh_max_size == 100_000
    assert full.reference_samples == 1_000_000
    q = suite.parse_args(["--quick"])
    assert q.sizes == [2000, 10_000] and q.surfaces == ["sphere", "torus", "tanglecube"]
    assert q.repeats == 1 and q.timeout == 60 and q.pygalmesh_max_size == 2000
    assert q.reference_samples == 50_000
    # Explicit options win over --quick; duplicates go, the order stays.
    q = suite.parse_args(
        ["--quick", "--sizes", "1e3", "--repeats", "2", "--surfaces", "torus", "sphere", "torus"]
    )
    assert q.sizes == [1000] and q.repeats == 2 and q.surfaces == ["torus", "sphere"]


@pytest.mark.parametrize(
    "argv",
    [["--sizes", "50"], ["--sizes", "many"], ["--repeats", "0"], ["--timeout", "-1"],
     ["--surfaces", "cube"], ["--meshers", "gmsh"], ["--reference-samples", "10"]],
    ids=["size", "size_text", "repeats", "timeout", "surface", "mesher", "samples"],
)  # fmt: skip
def test_command_line_rejects(argv, capsys):
    with pytest.raises(SystemExit) as info:
        suite.parse_args(argv)
    assert info.value.code == 2
    assert "error:" in capsys.readouterr().err


def test_python_mesher_runs_in_a_child_process(tmp_path):
    """The adapter's command runs the child side; its output is the run's fields."""
    rd = meshers.PythonMesher("rdmesh")
    args = argparse.Namespace(angle=30.0, seed=0, timeout=600)
    case = {"surface": "sphere", "size": 200, "params": {"radius": 0.3, "distance": 0.3}}
    path = tmp_path / f"sphere{rd.suffix}"
    res = measure.run_measured(rd.command(case, args, str(path)), rd.timeout(args))
    assert res["returncode"] == 0, res["stderr"]
    run = rd.parse(res, "rdmesh on sphere", {})
    v, f = meshfile.load_mesh(path)
    assert run["faces"] == len(f) and run["vertices"] == len(np.unique(f)) > 50
    np.testing.assert_allclose(np.linalg.norm(v[np.unique(f)], axis=1), 1.0, atol=1e-6)
    assert run["seconds"] > 0 and run["evaluations"] > run["vertices"]
    assert run["extra"]["complete"] is True
    # A failing child becomes a RuntimeError carrying its last line on stderr.
    case["surface"] = "nosuch"
    res = measure.run_measured(rd.command(case, args, None), rd.timeout(args))
    with pytest.raises(RuntimeError, match=r"exit 1: .*nosuch"):
        rd.parse(res, "rdmesh on nosuch", {})


def test_f_only_run_differentiates_f_itself():
    """rdmesh_f_only meshes the same surface from f alone: the same topology, and
    more evaluations (central differences) than the run with the exact gradient."""
    args = argparse.Namespace(angle=30.0, seed=0, timeout=600)
    case = {"surface": "torus", "size": 500, "params": {"radius": 0.2, "distance": 0.2}}
    runs = {}
    for name in ("rdmesh", "rdmesh_f_only"):
        m = meshers.PythonMesher(name)
        res = measure.run_measured(m.command(case, args, None), m.timeout(args))
        assert res["returncode"] == 0, res["stderr"]
        runs[name] = m.parse(res, name, {})
        assert runs[name]["extra"]["complete"] is True
    assert runs["rdmesh_f_only"]["evaluations"] > runs["rdmesh"]["evaluations"]
    v_g, v_f = runs["rdmesh"]["vertices"], runs["rdmesh_f_only"]["vertices"]
    assert abs(v_f - v_g) <= 0.1 * v_g


def _run(status="ok", seconds=1.0, vertices=100, rss=50.0):
    return {"status": status, "seconds": seconds, "process_seconds": seconds + 1,
            "vertices": vertices, "faces": 2 * vertices - 4, "peak_rss_mb": rss,
            "evaluations": 10 * vertices}  # fmt: skip


def test_summary_is_the_median_of_the_successful_runs():
    case = record.new_case("sphere", 100, "rdmesh", {})
    case["runs"] = [_run(seconds=3.0, rss=70), _run(status="failed"), _run(seconds=1.0, rss=None),
                    _run(seconds=2.0, rss=50)]  # fmt: skip
    record.summarise(case)
    summ = case["summary"]
    assert case["status"] == "ok"
    assert (summ["n_ok"], summ["n_runs"]) == (3, 4)
    assert summ["seconds"] == 2.0 and summ["seconds_all"] == [3.0, 1.0, 2.0]
    assert summ["process_seconds"] == 3.0
    assert summ["peak_rss_mb"] == 60.0  # median of the known ones
    assert summ["vertices_per_second"] == 50.0 and summ["evaluations_per_vertex"] == 10.0
    assert summ["deterministic"] is True
    case["runs"].append(_run(vertices=101))
    record.summarise(case)
    assert case["summary"]["deterministic"] is False
    # Without a successful run the case takes the last run's status.
    case["runs"] = [_run(status="failed"), _run(status="timeout")]
    record.summarise(case)
    assert case["status"] == "timeout" and case["summary"] is None


def test_sizes_are_written_as_in_the_tables():
    assert [record.fmt_size(n) for n in (500, 1000, 2500, 10_000, 1_000_000, 1_500_000)] == [
        "500", "1k", "2500", "10k", "1M", "1500k"
    ]  # fmt: skip


# ---------------------------------------------------------------------------
# The measurement of a child process
# ---------------------------------------------------------------------------


def test_run_measured_peak_rss_is_the_childs():
    # This test process holds numpy, scipy, rdmesh and matplotlib; the child's
    # figure must not inherit it (a child forked straight from here would
    # report at least this process's peak).
    parent_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    small = measure.run_measured([sys.executable, "-I", "-S", "-c", "pass"], timeout=600)
    assert small["returncode"] == 0 and not small["timed_out"]
    assert 0 < small["peak_rss_mb"] < parent_mb / 2
    # And it is the child's: 200 MB more when the child holds 200 MB more.
    big = measure.run_measured(
        [sys.executable, "-I", "-S", "-c", "x = b'x' * (200 * 2**20)"], timeout=600
    )
    assert 200 <= big["peak_rss_mb"] < small["peak_rss_mb"] + 250


def test_run_measured_memory_limit():
    code = "x = b'x' * (300 * 2**20)"
    res = measure.run_measured([sys.executable, "-I", "-S", "-c", code], 600, memory_limit_mb=150)
    assert res["returncode"] == 1 and "MemoryError" in res["stderr"]


def test_run_measured_timeout_and_exit_code():
    # Killed at the timeout, long before it would print: no exit code, no output.
    sleeper = "import time; time.sleep(30); print('finished')"
    res = measure.run_measured([sys.executable, "-c", sleeper], timeout=0.5)
    assert res["timed_out"] and res["returncode"] is None
    assert "finished" not in res["stdout"]
    res = measure.run_measured(
        [sys.executable, "-c", "import sys; print('out'); sys.exit(3)"], timeout=600
    )
    assert res["returncode"] == 3 and res["stdout"].strip() == "out" and not res["timed_out"]


def test_read_off(tmp_path):
    p = tmp_path / "m.off"
    p.write_text("OFF\n# comment\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n")
    v, f = meshfile.read_off(p)
    assert v.shape == (4, 3) and v[3].tolist() == [0, 0, 1]
    assert f.tolist() == [[0, 1, 2], [0, 1, 3]]


# ---------------------------------------------------------------------------
# metrics.py
# ---------------------------------------------------------------------------


def test_point_triangle_distance_matches_brute_force():
    rng = np.random.default_rng(1)
    tri = rng.normal(size=(200, 3, 3))
    p = rng.normal(size=(200, 3)) * 1.5
    exact = metrics.point_triangle_distance(p, tri[:, 0], tri[:, 1], tri[:, 2])
    # Dense barycentric samples of each triangle: a brute-force upper bound.
    n = 120
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    keep = i + j <= n
    u, v = i[keep] / n, j[keep] / n
    w = 1 - u - v
    pts = (w[None, :, None] * tri[:, None, 0] + u[None, :, None] * tri[:, None, 1]
           + v[None, :, None] * tri[:, None, 2])  # fmt: skip
    brute = np.linalg.norm(pts - p[:, None, :], axis=2).min(axis=1)
    edge = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
    assert np.all(exact <= brute + 1e-12)
    assert np.all(brute - exact <= edge / n)  # the sampling resolution


def test_point_triangle_distance_degenerate():
    a, b, c = np.zeros(3), np.array([1.0, 0, 0]), np.array([2.0, 0, 0])  # collinear
    d = metrics.point_triangle_distance(np.array([[0.5, 1.0, 0.0]]), a, b, c)
    assert d == pytest.approx([1.0])


def test_distance_to_surface_sphere_and_torus():
    rng = np.random.default_rng(2)
    n = rng.normal(size=(1000, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    delta = rng.uniform(-0.05, 0.05, 1000)
    d, foot, fallbacks = metrics.distance_to_surface(get("sphere"), n * (1 + delta)[:, None])
    assert fallbacks == 0
    np.testing.assert_allclose(d, np.abs(delta), atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(foot, axis=1), 1.0, atol=1e-12)

    # Torus R = 1, r = 0.4: points at distance |delta| from a known surface
    # point.  The gradient of f off the surface does not point at the closest
    # point, so this needs the refinement along the normal at the foot.
    delta = rng.uniform(-0.01, 0.01, 1000)
    u, v = rng.uniform(0, 2 * np.pi, (2, 1000))
    normal = np.column_stack([np.cos(u) * np.cos(v), np.sin(u) * np.cos(v), np.sin(v)])
    centre = np.column_stack([np.cos(u), np.sin(u), np.zeros(1000)])
    p = centre + (0.4 + delta)[:, None] * normal
    d, _, _ = metrics.distance_to_surface(get("torus"), p)
    np.testing.assert_allclose(d, np.abs(delta), atol=1e-10)


def test_topology_and_angles_of_a_tetrahedron():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    t = metrics.topology_stats(v, f, 1, 2)
    assert t["closed_manifold"] and t["components"] == 1 and t["euler"] == 2
    assert t["topology_ok"] is True
    t = metrics.topology_stats(v, f[:3], 1, 2)  # a hole
    assert not t["closed_manifold"] and t["topology_ok"] is False
    a = metrics.angle_stats(v, f)
    assert a["min_angle"] == pytest.approx(45.0)  # right isosceles faces
    assert a["frac_angles_below_30"] == 0
    ang = metrics.triangle_angles(v, f)
    np.testing.assert_allclose(ang.sum(axis=1), 180.0)


def test_compact_drops_unused_vertices():
    v = np.arange(15, dtype=float).reshape(5, 3)
    f = np.array([[4, 2, 0]])
    cv, cf = metrics.compact(v, f)
    assert cv.tolist() == [v[0].tolist(), v[2].tolist(), v[4].tolist()]
    assert cf.tolist() == [[2, 1, 0]]


# ---------------------------------------------------------------------------
# report.py: the targets (only met at sizes the quick run does not reach)
# ---------------------------------------------------------------------------


def _case(mesher, size, seconds, rss, status="ok"):
    summary = {"seconds": seconds, "peak_rss_mb": rss, "vertices": size, "n_ok": 1, "n_runs": 1}
    return {
        "surface": "torus",
        "size": size,
        "mesher": mesher,
        "status": status,
        "note": None,
        "runs": [],
        "params": {},
        "summary": summary if status == "ok" else None,
        "quality": None,
    }


def test_targets():
    import report

    res = {
        "settings": {"timeout": 3600},
        "cases": [
            _case("rdmesh", 10_000, 1.0, 100),  # below 100k: no targets
            _case("cgal_mesh_3", 10_000, 1.0, 50),
            _case("rdmesh", 100_000, 10.0, 500),
            _case("rdmesh_f_only", 100_000, 12.0, 700),
            _case("cgal_mesh_3", 100_000, 25.0, 400),
            _case("cgal_mesh_3_fast", 100_000, 16.0, 600),
            _case("cgal_delaunay_floor", 100_000, 2.0, 100),
            _case("pygalmesh", 100_000, 2000.0, 300),
            _case("rdmesh", 1_000_000, 100.0, 5000),
            _case("cgal_mesh_3", 1_000_000, 150.0, 30_000),
            _case("pygalmesh", 1_000_000, None, None, status="timeout"),
        ],
    }
    got = {(t["size"], t["target"]): t for t in report.targets(res)}
    assert all(size >= 100_000 for size, _ in got)
    t = got[(100_000, "rdmesh time <= 0.5 x Mesh_3 (manifold)")]
    assert t["value"] == pytest.approx(0.4) and t["passed"] is True
    t = got[(100_000, "rdmesh peak RSS <= Mesh_3 (manifold)")]
    assert t["value"] == pytest.approx(1.25) and t["passed"] is False
    t = got[(100_000, "rdmesh time <= 0.5 x Mesh_3 (no manifold)")]
    assert t["value"] == pytest.approx(0.625) and t["passed"] is False
    t = got[(100_000, "rdmesh peak RSS <= Mesh_3 (no manifold)")]
    assert t["passed"] is True
    t = got[(100_000, "rdmesh time <= 3 x floor")]
    assert t["value"] == pytest.approx(5.0) and t["passed"] is False
    # The headline: rdmesh over the faster Mesh_3 setting, named.
    h, f_only = sorted(
        (h for h in report.headline(res) if h["size"] == 100_000), key=lambda h: h["mesher"]
    )
    assert h["setting"] == "cgal_mesh_3_fast" and h["ratio"] == pytest.approx(0.625)
    # With f alone (the target), against the same setting.
    assert f_only["mesher"] == "rdmesh_f_only" and f_only["ratio"] == pytest.approx(0.75)
    t = got[(100_000, "rdmesh (f only) time <= 0.5 x Mesh_3 (no manifold)")]
    assert t["value"] == pytest.approx(0.75) and t["passed"] is False
    t = got[(100_000, "rdmesh (f only) peak RSS <= Mesh_3 (no manifold)")]
    assert t["value"] == pytest.approx(700 / 600) and t["passed"] is False
    md = report.ratio_table(res)
    assert "rdmesh ÷ Mesh_3 (no manifold)" in md and "5x" in md
    assert "| rdmesh (f only) | 12 |" in md
    t = got[(100_000, "rdmesh >= 100 x faster than pygalmesh")]
    assert t["value"] == pytest.approx(200) and t["passed"] is True
    t = got[(1_000_000, "rdmesh time <= 0.5 x Mesh_3 (manifold)")]
    assert t["passed"] is False
    t = got[(1_000_000, "rdmesh >= 100 x faster than pygalmesh")]
    assert t["passed"] is None and "> 36" in t["note"]  # 3600 s / 100 s
    assert got[(1_000_000, "rdmesh completes 1M within 24 GB")]["passed"] is True
    assert got[(1_000_000, "cgal_mesh_3 completes 1M within 24 GB")]["passed"] is False
    md = report.targets_table(res)
    assert "**pass**" in md and "**FAIL**" in md and "not measured" in md


def test_profile_run_reports_cpu_and_phases():
    cmd = [sys.executable, str(BENCH / "profile_run.py"), "sphere", "0.15", "--repeats", "2"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = [json.loads(line) for line in proc.stdout.splitlines()]
    assert len(rows) == 2
    for row in rows:
        assert row["vertices"] > 50
        assert row["wall_s"] > 0 and row["cpu_s"] > 0
        # Times are printed to 3 decimals and the ratio (of the unrounded
        # times) to 2: it lies in the range the rounded times allow.
        cpu, wall = row["cpu_s"], row["wall_s"]
        lo, hi = max(cpu - 5e-4, 0) / (wall + 5e-4), (cpu + 5e-4) / max(wall - 5e-4, 1e-9)
        assert lo - 0.005 <= row["cpu_per_wall"] <= hi + 0.005, row
        assert {"insert", "evaluate", "report"} <= set(row["phase_seconds"])
        assert row["peak_rss_mb"] > 50  # the interpreter with numpy and scipy alone
        # Each phase is part of the run (wall_s is rounded to 3 decimals).
        assert max(row["phase_seconds"].values()) <= wall + 5e-4
    # Deterministic: both runs give the same mesh size.
    assert rows[0]["vertices"] == rows[1]["vertices"]


def test_profile_run_rejects_unknown_surface():
    cmd = [sys.executable, str(BENCH / "profile_run.py"), "nosuch", "0.1"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 2
    assert "unknown surface 'nosuch'" in proc.stderr
