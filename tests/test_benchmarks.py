"""The benchmark suite (benchmarks/suite.py): a --quick run end to end, and its metrics.

The suite itself is not part of the package; these tests keep it from rotting.
They need the benchmark dependencies (benchmarks/requirements.txt) and are
skipped without scikit-image.  The CGAL meshers run when the reference program
builds (cmake + CGAL headers; the first build takes about a minute), and
pygalmesh when it is importable; otherwise the suite records them as
unavailable, which is checked too.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import time
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

QUICK_SURFACES = ("sphere", "torus")
QUICK_SIZE = 1000
STATUSES = {"ok", "failed", "timeout", "skipped", "unavailable"}
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _run_suite(out: Path, *extra: str, timeout: float = 600) -> subprocess.CompletedProcess:
    cmd = [sys.executable, str(BENCH / "suite.py"), "--out", str(out), *extra]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, check=False)


def _results(out: Path) -> dict:
    files = sorted(out.glob("*.json"))
    assert len(files) == 1, files
    return json.loads(files[0].read_text())


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    t0 = time.perf_counter()
    proc = _run_suite(out, "--quick", "--surfaces", *QUICK_SURFACES, "--sizes", str(QUICK_SIZE))
    elapsed = time.perf_counter() - t0
    assert proc.returncode == 0, proc.stderr[-4000:]
    return out, proc, _results(out), elapsed


def test_quick_run_is_fast(quick):
    _, _, res, _ = quick
    # The --quick promise is < 2 minutes; building the CGAL reference the
    # first time (about a minute) comes on top and is not counted.
    budget = 120 + res.get("cgal_build_seconds", 0.0)
    assert res["seconds"] < budget


def test_json_schema(quick):
    _, _, res, _ = quick
    assert res["schema"] == record.SCHEMA
    assert res["finished"] is True
    for key in ("date", "command", "machine", "versions", "settings", "calibration",
                "cases", "targets", "unavailable"):  # fmt: skip
        assert key in res, key
    s = res["settings"]
    assert s["quick"] is True and s["repeats"] == 1
    assert s["sizes"] == [QUICK_SIZE] and s["surfaces"] == list(QUICK_SURFACES)
    assert set(res["calibration"]) == set(QUICK_SURFACES)
    for cal in res["calibration"].values():
        assert cal["C"] > 0 and cal["area"] > 0 and cal["radius"] > 0

    cases = res["cases"]
    assert len(cases) == len(QUICK_SURFACES) * len(meshers.MESHERS)
    assert {(c["surface"], c["mesher"]) for c in cases} == {
        (s, m) for s in QUICK_SURFACES for m in meshers.MESHERS
    }
    for c in cases:
        assert c["status"] in STATUSES, c
        assert c["size"] == QUICK_SIZE
        if c["mesher"] in res["unavailable"]:
            assert c["status"] == "unavailable" and c["note"]
            continue
        # Everything that is installed must work on these easy surfaces.
        assert c["status"] == "ok", c
        (run,) = c["runs"]
        assert run["status"] == "ok" and run["error"] is None
        summ = c["summary"]
        for key in ("seconds", "vertices", "faces", "vertices_per_second", "peak_rss_mb",
                    "evaluations", "process_seconds"):  # fmt: skip
            assert summ[key] > 0, (c["mesher"], key)
        assert summ["process_seconds"] >= summ["seconds"]
        # Calibration maps the target to about that many vertices.
        assert 0.5 * QUICK_SIZE < summ["vertices"] < 2 * QUICK_SIZE, (c["mesher"], summ)
        q = c["quality"]
        assert q["vertices"] == summ["vertices"] and q["faces"] == summ["faces"]
        assert sum(q["min_angle_hist"]) == q["faces"]
        assert 0 <= q["frac_angles_below_30"] <= 1
        h = q["hausdorff"]
        assert h["two_sided"] == max(h["mesh_to_surface"]["max"], h["surface_to_mesh"]["max"])
        assert h["surface_samples"] >= 0.5 * s["reference_samples"]


def test_rdmesh_topology_matches_expected(quick):
    _, _, res, _ = quick
    for name in QUICK_SURFACES:
        (c,) = [c for c in res["cases"] if c["surface"] == name and c["mesher"] == "rdmesh"]
        t = c["quality"]["topology"]
        assert t["closed_manifold"] is True
        assert t["components"] == SURFACES[name].components
        assert t["euler"] == SURFACES[name].euler
        assert t["expected_euler"] == SURFACES[name].euler
        assert t["topology_ok"] is True
        assert c["quality"]["min_angle"] >= 30.0 - 1e-9


def test_sphere_hausdorff_is_the_sagitta(quick):
    """On the unit sphere the distance is the sag of the largest facets.

    A facet whose surface Delaunay ball has radius <= r lies within
    1 - sqrt(1 - r^2) of the sphere; refinement drives facets close to r.
    """
    _, _, res, _ = quick
    for c in res["cases"]:
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
    out, proc, res, _ = quick
    stem = sorted(out.glob("*.json"))[0].stem
    md = (out / f"{stem}.md").read_text()
    for heading in ("## Performance", "## Quality", "## Targets", "## Plots"):
        assert heading in md
    for c in res["cases"]:
        assert f"| {c['surface']} | 1k | {c['mesher']} |" in md
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
# The measurement of a child process
# ---------------------------------------------------------------------------


def test_run_measured_peak_rss_is_the_childs():
    # This test process holds numpy, scipy, rdmesh and matplotlib (far more
    # than 40 MB); the child's figure must not inherit it.
    small = measure.run_measured([sys.executable, "-I", "-S", "-c", "pass"], timeout=60)
    assert small["returncode"] == 0 and not small["timed_out"]
    assert small["peak_rss_mb"] < 40
    big = measure.run_measured(
        [sys.executable, "-I", "-S", "-c", "x = b'x' * (200 * 2**20)"], timeout=60
    )
    assert 200 <= big["peak_rss_mb"] < 300


def test_run_measured_memory_limit():
    code = "x = b'x' * (300 * 2**20)"
    res = measure.run_measured([sys.executable, "-I", "-S", "-c", code], 60, memory_limit_mb=150)
    assert res["returncode"] == 1 and "MemoryError" in res["stderr"]


def test_run_measured_timeout_and_exit_code():
    t0 = time.perf_counter()
    res = measure.run_measured([sys.executable, "-c", "import time; time.sleep(30)"], timeout=0.5)
    assert res["timed_out"] and res["returncode"] is None
    assert time.perf_counter() - t0 < 10
    res = measure.run_measured(
        [sys.executable, "-c", "import sys; print('out'); sys.exit(3)"], timeout=60
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
            _case("cgal_mesh_3", 100_000, 25.0, 400),
            _case("pygalmesh", 100_000, 2000.0, 300),
            _case("rdmesh", 1_000_000, 100.0, 5000),
            _case("cgal_mesh_3", 1_000_000, 150.0, 30_000),
            _case("pygalmesh", 1_000_000, None, None, status="timeout"),
        ],
    }
    got = {(t["size"], t["target"]): t for t in report.targets(res)}
    assert all(size >= 100_000 for size, _ in got)
    t = got[(100_000, "rdmesh time <= 0.5 x make_mesh_3")]
    assert t["value"] == pytest.approx(0.4) and t["passed"] is True
    t = got[(100_000, "rdmesh peak RSS <= make_mesh_3")]
    assert t["value"] == pytest.approx(1.25) and t["passed"] is False
    t = got[(100_000, "rdmesh >= 100 x faster than pygalmesh")]
    assert t["value"] == pytest.approx(200) and t["passed"] is True
    t = got[(1_000_000, "rdmesh time <= 0.5 x make_mesh_3")]
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
        assert math.isclose(row["cpu_per_wall"], row["cpu_s"] / row["wall_s"], abs_tol=0.01)
        assert {"insert", "evaluate", "report"} <= set(row["phase_seconds"])
        assert row["peak_rss_mb"] > 50  # the interpreter with numpy and scipy alone
        assert max(row["phase_seconds"].values()) <= row["wall_s"]
    # Deterministic: both runs give the same mesh size.
    assert rows[0]["vertices"] == rows[1]["vertices"]


def test_profile_run_rejects_unknown_surface():
    cmd = [sys.executable, str(BENCH / "profile_run.py"), "nosuch", "0.1"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 2
    assert "unknown surface 'nosuch'" in proc.stderr
