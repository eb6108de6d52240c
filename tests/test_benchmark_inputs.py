"""The suite's other inputs (``suite.py --inputs volume remesh clipped``).

The end-to-end run (one case of each input at 500 vertices, about a minute
with the debug checks on) is ``slow``; so is the one with CGAL's
Manifold_with_boundary_tag row, which builds the CGAL reference on a fresh
machine.  The command line, the topology with boundary and the input
parameters are checked in the default run.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("skimage")
pytest.importorskip("matplotlib")

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))

import input_clipped  # noqa: E402
import input_volume  # noqa: E402
import metrics  # noqa: E402
import suite  # noqa: E402

SIZE = 500
CASES = ["CT phantom", "plane disk", "torus mesh"]
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _run(out: Path, *meshers: str) -> dict:
    cmd = [sys.executable, str(BENCH / "suite.py"), "--out", str(out),
           "--inputs", "volume", "remesh", "clipped", "--cases", *CASES,
           "--sizes", str(SIZE), "--repeats", "1", "--reference-samples", "3000",
           "--timeout", "300", "--meshers", *meshers]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900, check=False)
    assert proc.returncode == 0, proc.stderr[-4000:]
    (path,) = out.glob("*.json")
    res = json.loads(path.read_text())
    res["_stem"] = path.stem
    res["_stdout"] = proc.stdout
    return res


def _case(res: dict, surface: str, mesher: str) -> dict:
    (c,) = [c for c in res["cases"] if c["surface"] == surface and c["mesher"] == mesher]
    return c


@pytest.fixture(scope="module")
def rows(tmp_path_factory) -> tuple[Path, dict]:
    out = tmp_path_factory.mktemp("bench-inputs")
    return out, _run(out, "rdmesh", "marching_cubes", "input", "pymeshlab")


@pytest.mark.slow
def test_record_has_one_case_per_input_case_and_mesher(rows):
    _, res = rows
    assert res["finished"] is True
    assert res["settings"]["inputs"] == ["volume", "remesh", "clipped"]
    got = {(c["input"], c["surface"], c["mesher"]) for c in res["cases"]}
    assert got == {
        ("volume", "CT phantom", "rdmesh"),
        ("volume", "CT phantom", "marching_cubes"),
        ("remesh", "torus mesh", "input"),
        ("remesh", "torus mesh", "rdmesh"),
        ("remesh", "torus mesh", "pymeshlab"),
        ("clipped", "plane disk", "rdmesh"),
        ("clipped", "plane disk", "marching_cubes"),
    }
    for c in res["cases"]:
        if c["status"] == "unavailable":  # pymeshlab may not be installed
            assert c["mesher"] == "pymeshlab" and "pymeshlab" in c["note"]
            continue
        assert c["status"] == "ok", c
        q = c["quality"]
        assert q["vertices"] == c["summary"]["vertices"] > 100
        assert sum(q["min_angle_hist"]) == q["faces"]
        if c["mesher"] != "input":
            assert c["summary"]["seconds"] > 0 and c["summary"]["peak_rss_mb"] > 0


@pytest.mark.slow
def test_phantom_rows_have_the_bones_topology(rows):
    _, res = rows
    rd = _case(res, "CT phantom", "rdmesh")["quality"]
    t = rd["topology"]
    assert sorted(t["euler_per_component"]) == [0, 2, 2]
    assert t["closed_manifold"] is True and t["topology_ok"] is True
    assert rd["min_angle"] >= 30.0 - 1e-9
    # Within a voxel of the cubic interpolant.
    assert 0 < rd["hausdorff"]["two_sided"] < rd["voxel"]
    mc = _case(res, "CT phantom", "marching_cubes")["quality"]
    assert sorted(mc["topology"]["euler_per_component"]) == [0, 2, 2]
    assert mc["min_angle"] < 30.0  # marching cubes has no angle bound


@pytest.mark.slow
def test_clipped_disk_rows_have_one_boundary_loop(rows):
    _, res = rows
    rd = _case(res, "plane disk", "rdmesh")["quality"]
    t = rd["topology"]
    assert (t["components"], t["euler"], t["boundary_loops"]) == (1, 1, 1)
    assert t["manifold_with_boundary"] is True and t["topology_ok"] is True
    # rdmesh's boundary vertices lie on the sphere; interior triangles keep the bound.
    assert rd["boundary_offset"] < 1e-9
    assert rd["min_angle_interior"] >= 30.0 - 1e-9
    mc = _case(res, "plane disk", "marching_cubes")["quality"]
    assert mc["topology"]["boundary_loops"] == 1
    assert mc["boundary_offset"] > 1e-3  # cut at grid cells, off the sphere


@pytest.mark.slow
def test_remesh_rows_measure_against_the_input(rows):
    _, res = rows
    inp = _case(res, "torus mesh", "input")
    assert inp["quality"]["hausdorff"]["two_sided"] < 1e-12
    assert inp["summary"]["peak_rss_mb"] is None
    rd = _case(res, "torus mesh", "rdmesh")
    q, r = rd["quality"], rd["params"]["radius"]
    assert q["topology"]["topology_ok"] is True and q["min_angle"] >= 30.0 - 1e-9
    assert 0 < q["hausdorff"]["two_sided"] < r


@pytest.mark.slow
def test_report_and_plots_of_the_inputs(rows):
    out, res = rows
    stem = res["_stem"]
    md = (out / f"{stem}.md").read_text()
    for heading in ("## Volumes", "## Remeshing", "## Clipped surfaces"):
        assert heading in md
    assert "## Calibration" not in md  # no built-in surface was run
    assert "| CT phantom | 500 | rdmesh | ok |" in md
    assert "[0, 2, 2] ([0, 2, 2])" in md
    assert "| plane disk | 500 | rdmesh | ok |" in md and "| 1 (1) |" in md
    assert "### Volumes" in res["_stdout"]
    for name in ("volume", "remesh", "clipped"):
        for plot in ("time", "memory", "hausdorff", "angles"):
            png = out / f"{stem}-{name}-{plot}.png"
            assert f"]({png.name})" in md
            assert png.read_bytes()[:8] == PNG_MAGIC


@pytest.mark.slow  # builds the CGAL reference on a fresh machine (a minute or two)
def test_cgal_with_boundary_row(tmp_path):
    cmd = [sys.executable, str(BENCH / "suite.py"), "--out", str(tmp_path),
           "--inputs", "clipped", "--cases", "long cylinder", "--sizes", str(SIZE),
           "--repeats", "1", "--reference-samples", "3000",
           "--meshers", "cgal_surface_mesher"]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900, check=False)
    assert proc.returncode == 0, proc.stderr[-4000:]
    (path,) = tmp_path.glob("*.json")
    (c,) = json.loads(path.read_text())["cases"]
    if c["status"] == "unavailable":
        pytest.skip(f"CGAL reference not available: {c['note']}")
    t = c["quality"]["topology"]
    assert (t["components"], t["euler"], t["boundary_loops"]) == (1, 0, 2)
    # CGAL's boundary is where its oracle clipped the duals: off the sphere.
    assert c["quality"]["boundary_offset"] > 1e-3


# ---------------------------------------------------------------------------
# The parts
# ---------------------------------------------------------------------------


def test_command_line_inputs():
    a = suite.parse_args([])
    assert a.inputs == ["implicit"] and a.input_meshers is None and a.cases is None
    a = suite.parse_args(["--inputs", "volume", "clipped", "--meshers", "rdmesh", "pymeshlab",
                          "--cases", "plane disk"])  # fmt: skip
    assert a.inputs == ["volume", "clipped"] and a.cases == ["plane disk"]
    assert a.input_meshers == ["rdmesh", "pymeshlab"] and a.meshers == ["rdmesh"]


@pytest.mark.parametrize(
    "argv",
    [["--inputs", "images"], ["--cases", "nosuch"], ["--meshers", "pymeshlab"]],
    ids=["input", "case", "no-implicit-mesher"],
)
def test_command_line_rejects_inputs(argv, capsys):
    with pytest.raises(SystemExit) as info:
        suite.parse_args(argv)
    assert info.value.code == 2
    assert "error:" in capsys.readouterr().err


def test_topology_with_boundary():
    # A square of two triangles: a disk, one boundary loop.
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    t = metrics.topology_stats(v, f, 1, 1, expected_loops=1)
    assert t["manifold_with_boundary"] and not t["closed_manifold"]
    assert (t["boundary_loops"], t["euler"], t["topology_ok"]) == (1, 1, True)
    # Expecting it closed (no loops given) fails; a wrong per-component list too.
    assert metrics.topology_stats(v, f, 1, 1)["topology_ok"] is False
    t = metrics.topology_stats(v, f, 1, 1, expected_loops=1, expected_per_component=[2])
    assert t["topology_ok"] is False


def test_volume_scale_never_below_the_known_topology():
    p = input_volume.INPUT.params("CT phantom", 100)
    assert p["scale"] == 1.0 and p["shape"] == [48, 48, 32]
    small, big = (input_volume.INPUT.params("torus volume", n) for n in (100, 20_000))
    assert small["scale"] == 0.6 and big["scale"] > 1.0
    assert big["radius"] < small["radius"]


def test_clipped_marching_cubes_stays_in_the_ball():
    s = input_clipped.CASES["long cylinder"].surface()
    v, f, n = input_clipped.clipped_marching_cubes(s, 0.1)
    assert n > 0 and len(f) > 100
    assert np.linalg.norm(v, axis=1).max() <= 1.0
    t = metrics.topology_stats(v, f, 1, 0, expected_loops=2)
    assert t["topology_ok"] is True


# ---------------------------------------------------------------------------
# CGAL's gray-image Mesh_3 (the reference program's mesh_3_image mode)
# ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def cgal_exe():
    """The CGAL reference program (built on first use, a minute or two)."""
    import cgal_runner

    try:
        return cgal_runner.build_reference()
    except (cgal_runner.CgalReferenceError, OSError) as exc:
        pytest.skip(f"CGAL reference not available: {exc}")


def _mesh_image(exe, tmp_path, case: str, scale: float, size: int, init: str):
    """Run mesh_3_image on a case's volume: the JSON result, the mesh, and the
    volume's trilinear ``VolumeSurface`` (the object CGAL meshes)."""
    import cgal_runner
    import meshfile
    import rdmesh

    vol, kw = input_volume.CASES[case].build(scale)
    lin = rdmesh.VolumeSurface(vol, interpolation="linear", **kw)
    raw, off = tmp_path / "volume.f32", tmp_path / "mesh.off"
    cgal_runner.write_volume(raw, vol)
    r = input_volume.INPUT.params(case, size)["radius"]
    cmd = cgal_runner.image_command(
        exe, raw, vol.shape, lin.spacing, lin.origin, kw["isovalue"], 30, r, r, init=init, out=off
    )
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, check=False)
    out = cgal_runner.parse_reference_output(proc.returncode, proc.stdout, proc.stderr)
    v, f = metrics.compact(*meshfile.load_mesh(off))
    return out, v, f, lin


def test_write_volume_is_x_fastest_little_endian_float32(tmp_path):
    import cgal_runner

    vol = np.arange(24, dtype=float).reshape(2, 3, 4)  # vol[i, j, k] = 12 i + 4 j + k
    cgal_runner.write_volume(tmp_path / "v.f32", vol)
    data = np.fromfile(tmp_path / "v.f32", dtype="<f4")
    i, j, k = 1, 2, 3
    assert data.size == 24 and data[i + 2 * (j + 3 * k)] == vol[i, j, k]
    cmd = cgal_runner.image_command("exe", "v.f32", vol.shape, (1, 1, 1.5), (0, 0, -1), 0.5,
                                    30, 0.1, 0.1, init="components")  # fmt: skip
    assert cmd[cmd.index("--dims") + 1] == "2,3,4"
    assert cmd[cmd.index("--spacing") + 1] == "1.0,1.0,1.5"
    with pytest.raises(ValueError):
        cgal_runner.image_command("exe", "v.f32", vol.shape, (1, 1, 1), (0, 0, 0), 0.5, 30,
                                  0.1, 0.1, init="nosuch")  # fmt: skip


@pytest.mark.slow  # builds the CGAL reference on a fresh machine (a minute or two)
def test_cgal_image_mesher_closes_the_torus_volume(cgal_exe, tmp_path):
    out, v, f, lin = _mesh_image(cgal_exe, tmp_path, "torus volume", 1.0, 2000, "random")
    assert (out["closed"], out["components"], out["euler_characteristic"]) == (True, 1, 0)
    t = metrics.topology_stats(v, f, 1, 0)
    assert t["closed_manifold"] is True and t["topology_ok"] is True
    lo, hi = lin.box
    assert np.all(v >= lo) and np.all(v <= hi)
    # On the trilinear isosurface of the same samples (so the same axes,
    # spacing and origin), and outward: about the torus's volume 2 pi^2 R r^2.
    assert np.abs(lin.f(v)).max() < 1e-3 * lin.spacing.min()
    a, b, c = (v[f[:, i]] for i in range(3))
    volume = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6
    assert volume == pytest.approx(2 * np.pi**2 * 1.0 * 0.4**2, rel=0.05)


@pytest.mark.slow
def test_cgal_image_mesher_seeded_finds_the_phantom_bones(cgal_exe, tmp_path):
    out, v, f, lin = _mesh_image(cgal_exe, tmp_path, "CT phantom", 1.0, 2000, "components")
    assert (out["closed"], out["components"]) == (True, 3)
    t = metrics.topology_stats(v, f, 3, 4, expected_per_component=[0, 2, 2])
    assert t["closed_manifold"] is True and t["topology_ok"] is True
    lo, hi = lin.box
    assert np.all(v >= lo) and np.all(v <= hi)
    # The phantom is asymmetric along every axis: a swapped axis would be far off.
    assert np.abs(lin.f(v)).max() < 1e-3 * lin.spacing.min()
    assert metrics.angle_stats(v, f, 30.0)["min_angle"] >= 30.0 - 0.5


@pytest.mark.slow
def test_cgal_image_rows_in_the_suite(tmp_path):
    cmd = [sys.executable, str(BENCH / "suite.py"), "--out", str(tmp_path),
           "--inputs", "volume", "--cases", "torus volume", "--sizes", str(SIZE),
           "--repeats", "1", "--reference-samples", "3000",
           "--meshers", "cgal_mesh_3_image", "cgal_mesh_3_image_components"]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900, check=False)
    assert proc.returncode == 0, proc.stderr[-4000:]
    (path,) = tmp_path.glob("*.json")
    cases = json.loads(path.read_text())["cases"]
    assert {c["mesher"] for c in cases} == {"cgal_mesh_3_image", "cgal_mesh_3_image_components"}
    for c in cases:
        if c["status"] == "unavailable":
            pytest.skip(f"CGAL reference not available: {c['note']}")
        assert c["status"] == "ok", c
        q = c["quality"]
        assert q["topology"]["topology_ok"] is True
        assert q["topology"]["closed_manifold"] is True
        assert q["vertices"] == c["summary"]["vertices"] > 100
        # Trilinear against the cubic interpolant: within a voxel.
        assert 0 < q["hausdorff"]["two_sided"] < q["voxel"]
        assert sum(q["min_angle_hist"]) == q["faces"]


# ---------------------------------------------------------------------------
# Surfaces clipped to a box (the clipped_box input)
# ---------------------------------------------------------------------------

BOX_CASES = ("gyroid in a cube", "plane in a box")


def _box(case: str) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = np.asarray(input_clipped.CASES[case].box, float)
    return lo, hi


def _boundary_vertices(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    from rdmesh.topology.complex import complex_status

    n = len(v)
    st = complex_status(f, n)
    key = st.edge_key[st.edge_count == 1]
    return np.unique(np.concatenate([key // n, key % n]))


def test_box_cases_are_their_own_input():
    import inputs

    box = inputs.kind("clipped_box")
    assert box.cases() == BOX_CASES
    assert not set(BOX_CASES) & set(inputs.kind("clipped").cases())
    assert box.meshers == ("rdmesh", "cgal_mesh_3_box", "marching_cubes")
    a = suite.parse_args(["--inputs", "clipped_box", "--cases", "plane in a box",
                          "--meshers", "cgal_mesh_3_box"])  # fmt: skip
    assert a.inputs == ["clipped_box"] and a.input_meshers == ["cgal_mesh_3_box"]
    # The surface has the case's box; its sphere holds the box.
    s = input_clipped.CASES["plane in a box"].surface()
    lo, hi = _box("plane in a box")
    np.testing.assert_array_equal(s.clip_box, [lo, hi])
    assert np.linalg.norm(hi - s.centre) < s.radius


def test_box_offset_is_the_distance_to_the_box_surface():
    lo, hi = np.zeros(3), np.array([1.0, 2.0, 3.0])
    p = np.array([[0.5, 1.0, 1.0], [0.2, 0.3, 0.4], [1.0, 1.0, 1.0], [2.0, 1.0, 1.0],
                  [2.0, 3.0, 1.0], [-1.0, -1.0, -1.0]])  # fmt: skip
    np.testing.assert_allclose(
        input_clipped.box_offset(p, lo, hi), [0.5, 0.2, 0.0, 1.0, np.sqrt(2), np.sqrt(3)]
    )


@pytest.mark.parametrize("case", BOX_CASES)
def test_box_marching_cubes_spans_the_box(case):
    s = input_clipped.CASES[case].surface()
    lo, hi = _box(case)
    v, f, n = input_clipped.box_marching_cubes(s, 0.1 * float(np.min(hi - lo)))
    assert n > 0 and len(f) > 100
    # Every vertex in the box, the boundary on its faces (the grid spans it).
    assert np.all(v >= lo) and np.all(v <= hi)
    bv = _boundary_vertices(v, f)
    assert len(bv) > 0
    assert input_clipped.box_offset(v[bv], lo, hi).max() <= 1e-12 * float(np.max(hi - lo))
    if case == "plane in a box":
        t = metrics.topology_stats(v, f, 1, 1, expected_loops=1)
        assert t["topology_ok"] is True


def test_box_marching_cubes_needs_a_box():
    s = input_clipped.CASES["plane disk"].surface()
    with pytest.raises(ValueError, match="no clip_box"):
        input_clipped.box_marching_cubes(s, 0.1)


def test_mesh_3_box_takes_only_the_box_surfaces():
    import cgal_runner

    cmd = cgal_runner.reference_command("exe", "mesh_3_box", "box_plane", 30, 0.1, 0.1)
    assert cmd[:5] == ["exe", "--mesher", "mesh_3_box", "--surface", "box_plane"]
    with pytest.raises(ValueError, match="mesh_3_box"):
        cgal_runner.reference_command("exe", "mesh_3_box", "sphere", 30, 0.1, 0.1)
    with pytest.raises(ValueError, match="mesh_3_box"):
        cgal_runner.reference_command("exe", "mesh_3_fast", "box_gyroid", 30, 0.1, 0.1)
    # The case table and the program name the same surfaces.
    names = {input_clipped.CASES[c].cgal for c in BOX_CASES}
    assert names == set(cgal_runner.BOX_SURFACES)


@pytest.fixture(scope="module")
def box_rows(tmp_path_factory) -> dict:
    out = tmp_path_factory.mktemp("bench-box")
    cmd = [sys.executable, str(BENCH / "suite.py"), "--out", str(out),
           "--inputs", "clipped_box", "--cases", "plane in a box", "--sizes", str(SIZE),
           "--repeats", "1", "--reference-samples", "3000", "--timeout", "300",
           "--meshers", "rdmesh", "marching_cubes", "cgal_mesh_3_box"]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900, check=False)
    assert proc.returncode == 0, proc.stderr[-4000:]
    (path,) = out.glob("*.json")
    res = json.loads(path.read_text())
    res["_md"] = path.with_suffix(".md").read_text()
    return res


@pytest.mark.slow
def test_box_plane_rows_are_a_disk_with_its_boundary_on_the_box(box_rows):
    assert box_rows["finished"] is True
    rd = _case(box_rows, "plane in a box", "rdmesh")
    assert rd["status"] == "ok", rd
    q = rd["quality"]
    t = q["topology"]
    assert (t["components"], t["euler"], t["boundary_loops"]) == (1, 1, 1)
    assert t["manifold_with_boundary"] is True and t["topology_ok"] is True
    # rdmesh puts its boundary vertices on the box faces (their coordinate set
    # to the face's); interior triangles keep the angle bound.
    assert q["boundary_offset"] <= 1e-12
    assert q["min_angle_interior"] >= 30.0 - 1e-9
    mc = _case(box_rows, "plane in a box", "marching_cubes")
    assert mc["status"] == "ok", mc
    assert mc["quality"]["topology"]["boundary_loops"] == 1
    assert mc["quality"]["boundary_offset"] <= 1e-12  # the grid spans the box
    assert "## Surfaces clipped to a box" in box_rows["_md"]
    assert "| plane in a box | 500 | rdmesh | ok |" in box_rows["_md"]


@pytest.mark.slow  # builds the CGAL reference on a fresh machine (a minute or two)
def test_box_plane_cgal_row(box_rows):
    c = _case(box_rows, "plane in a box", "cgal_mesh_3_box")
    if c["status"] == "unavailable":
        pytest.skip(f"CGAL reference not available: {c['note']}")
    assert c["status"] == "ok", c
    q = c["quality"]
    assert q["vertices"] == c["summary"]["vertices"] > 100
    assert q["topology"]["boundary_loops"] >= 1
    # Mesh_3 meshed the box faces too; only the facets between 1 and 2 are kept.
    (run,) = c["runs"]
    assert run["extra"]["complex_facets"] > q["faces"]
    assert run["extra"]["box"] == [*_box("plane in a box")[0], *_box("plane in a box")[1]]


def _mesh_3_box(exe, tmp_path, case: str, r: float):
    import cgal_runner
    import meshfile

    off = tmp_path / f"{input_clipped.CASES[case].cgal}.off"
    out = cgal_runner.run_reference(
        exe, "mesh_3_box", input_clipped.CASES[case].cgal, 30, r, r, out=off, timeout=600
    )
    v, f = metrics.compact(*meshfile.load_mesh(off))
    return out, v, f


@pytest.mark.slow
@pytest.mark.parametrize(("case", "r"), [("plane in a box", 0.05), ("gyroid in a cube", 0.2)])
def test_cgal_mesh_3_box_keeps_only_the_clipped_surface(cgal_exe, tmp_path, case, r):
    out, v, f = _mesh_3_box(cgal_exe, tmp_path, case, r)
    lo, hi = _box(case)
    assert out["box"] == [*lo, *hi]
    assert len(f) == out["faces"] > 100 and out["complex_facets"] > len(f)
    # Every vertex in the box, up to the oracle's bisection error (1e-6 of
    # the domain's half diagonal).
    tol = 1e-5 * float(np.linalg.norm(hi - lo))
    assert np.all(v >= lo - tol) and np.all(v <= hi + tol)
    # A boundary, and no facet of a box face: no triangle with its three
    # vertices on one face.
    assert len(_boundary_vertices(v, f)) > 0
    on = np.concatenate([np.abs(v - lo), np.abs(hi - v)], axis=1) <= tol
    assert not on[f].all(axis=1).any()
    # The facets are oriented out of subdomain 1 (f < 0): along grad f.
    s = input_clipped.CASES[case].surface()
    a, b, c = (v[f[:, i]] for i in range(3))
    normal = np.cross(b - a, c - a)
    g = s.grad((a + b + c) / 3)
    assert np.einsum("ij,ij->i", normal, g).sum() > 0.9 * np.linalg.norm(normal, axis=1).dot(
        np.linalg.norm(g, axis=1)
    )
