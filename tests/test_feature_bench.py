"""Issue 27's feature benchmark (benchmarks/features.py) and its parts.

Default run: the metrics of ``feature_metrics`` on hand-built meshes whose
answers are known, the CAD shapes of ``cad_shapes`` (closed, genus, their
listed creases are exactly the mesh's sharp edges), the exact curves of the
implicit box and box_ball, ``cgal_runner.write_polylines`` and the script on
its input rows.  ``slow``: builds the CGAL reference and runs its features
modes.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))

import cad_shapes  # noqa: E402
import cgal_runner  # noqa: E402
import crease_shapes  # noqa: E402
import feature_metrics as fm  # noqa: E402


def _cube(levels: int = 2, scale: float = 1.0):
    """The cube [-scale, scale]^3, each face split into 2 * 4**levels right triangles."""
    m = trimesh.creation.box(extents=(2.0, 2.0, 2.0))
    v, f = np.asarray(m.vertices, float), np.asarray(m.faces, np.int64)
    for _ in range(levels):
        v, f = trimesh.remesh.subdivide(v, f)
    return np.asarray(v) * scale, np.asarray(f)


def _segment_pairs(shape, curves) -> set:
    """The curves' segments as sorted vertex-index pairs of the shape's mesh."""
    from scipy.spatial import cKDTree

    d, _ = cKDTree(shape.vertices).query(np.vstack(curves))
    assert d.max() == 0.0, "curve points are not mesh vertices"
    tree = cKDTree(shape.vertices)
    pairs = set()
    for c in curves:
        _, idx = tree.query(c)
        pairs |= {tuple(sorted(map(int, p))) for p in zip(idx[:-1], idx[1:], strict=True)}
    return pairs


# ---------------------------------------------------------------------------
# feature_metrics on meshes with known answers
# ---------------------------------------------------------------------------


def test_cube_with_its_edges_is_fully_covered():
    v, f = _cube()
    cov = fm.crease_coverage(v, f, cad_shapes.box_curves())
    assert cov["coverage"] == pytest.approx(1.0, abs=1e-12)
    assert cov["total_length"] == pytest.approx(24.0)
    assert cov["per_curve"] == pytest.approx([1.0] * 12)
    assert cov["edges_on_curves"] == 12 * 4  # each edge in 4 pieces
    cv = fm.crease_vertex_distance(v, cad_shapes.box_curves())
    assert cv["count"] == 8 + 12 * 3 and cv["max_distance"] < 1e-15
    assert fm.corner_hits(v, cad_shapes.box_corners())["hit"] == 8


def test_chamfered_cube_covers_nothing():
    c = 0.9
    pts = []
    for perm in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        for sx in (-1, 1):
            for sy in (-1, 1):
                for sz in (-1, 1):
                    p = np.array([sx * 1.0, sy * c, sz * c])
                    pts.append(p[list(perm)])
    hull = trimesh.convex.convex_hull(np.array(pts))
    v, f = np.asarray(hull.vertices), np.asarray(hull.faces)
    cov = fm.crease_coverage(v, f, cad_shapes.box_curves())
    assert cov["coverage"] == 0.0 and cov["edges_on_curves"] == 0
    assert fm.crease_vertex_distance(v, cad_shapes.box_curves())["count"] == 0
    assert fm.corner_hits(v, cad_shapes.box_corners())["hit"] == 0
    # Deepest at the centroids of the corner cuts, x = y = z = 2.8 / 3.
    sd = fm.surface_distance(v, f, cad_shapes.box_sdf, n_random=20000)
    assert sd["max"] == pytest.approx(0.2 / 3, rel=1e-9)


def test_vertex_moved_off_a_crease():
    v, f = _cube()
    k = int(np.flatnonzero(np.all(np.isclose(v, [0.0, -1.0, -1.0]), axis=1))[0])
    v = v.copy()
    v[k] += 1e-3 * np.array([0.0, -1.0, -1.0]) / math.sqrt(2)
    curves = cad_shapes.box_curves()
    cv = fm.crease_vertex_distance(v, curves, near=1e-2)
    assert cv["count"] == 44
    assert cv["max_distance"] == pytest.approx(1e-3, rel=1e-9)
    # Within 1e-6: the moved vertex is no longer a crease vertex.
    assert fm.crease_vertex_distance(v, curves)["count"] == 43
    # Its two crease edges (0.5 long each) are off the curve.
    cov = fm.crease_coverage(v, f, curves)
    assert cov["coverage"] == pytest.approx(23.0 / 24.0, abs=1e-12)
    assert sorted(cov["per_curve"])[0] == pytest.approx(0.5)


def test_closed_loop_and_chords():
    n = 8
    t = 2 * np.pi * np.arange(n) / n
    rim = np.column_stack([np.cos(t), np.sin(t), np.zeros(n)])
    loop = np.vstack([rim, rim[:1]])
    # A fan from vertex 0: the rim's n edges and n - 3 diagonals.
    fan = np.array([[0, i, i + 1] for i in range(1, n - 1)])
    cov = fm.crease_coverage(rim, fan, [loop])
    assert cov["coverage"] == pytest.approx(1.0, abs=1e-12)
    # The diagonals join two points of the loop but do not follow it.
    assert cov["edges_on_curves"] == n
    # Half of the fan: rim edges 0-1 ... 3-4.
    half = fm.crease_coverage(rim, fan[: (n - 2) // 2], [loop])
    assert half["coverage"] == pytest.approx(4.0 / n, abs=1e-12)
    # The edge (n-1)-0 closes the loop (its parameters wrap around).
    last = fm.crease_coverage(rim, np.array([[0, n - 2, n - 1]]), [loop])
    assert last["coverage"] == pytest.approx(2.0 / n, abs=1e-12)
    assert last["edges_on_curves"] == 2


def test_overlapping_edges_count_once():
    # Edges [0, 1] and [0, 0.5] of the segment from 0 to 2 (a non-manifold
    # soup): the union covers half of it.
    v = np.array([[0, 0, 0], [1, 0, 0], [0.5, 0, 0], [0, 1, 0], [0, -1, 0]], float)
    f = np.array([[0, 1, 3], [0, 2, 4]])
    cov = fm.crease_coverage(v, f, [np.array([[0.0, 0, 0], [2.0, 0, 0]])])
    assert cov["coverage"] == pytest.approx(0.5, abs=1e-12)
    assert cov["edges_on_curves"] == 2


def test_arc_distances_and_sagitta():
    arc = cad_shapes.box_ball_curves()[-1]
    assert arc.radius == pytest.approx(0.8) and arc.sweep == pytest.approx(np.pi / 2)
    pts = arc.sample(64)
    d, s = arc.project(pts)
    assert d.max() < 1e-15
    assert s[-1] == pytest.approx(arc.length) and np.all(np.diff(s) > 0)
    mid = 0.5 * (pts[1:] + pts[:-1])
    dm, _ = arc.project(mid)
    # The design note's "6e-5 sagitta" of a 64-chord arc of radius 0.8.
    assert dm.max() == pytest.approx(arc.sagitta(64), rel=1e-9)
    assert arc.sagitta(64) == pytest.approx(6.02e-5, rel=1e-3)
    # Off the arc's ends the distance is to the nearer end.
    beyond = np.asarray(arc.start) + np.array([[0.0, 0.0, 0.5]])
    assert arc.project(beyond)[0][0] == pytest.approx(0.5)


def test_circle_is_one_closed_curve():
    circle = fm.Circle((0.0, 0.0, 1.0), 0.5, (0.0, 0.0, 1.0))
    assert circle.closed and circle.length == pytest.approx(np.pi)
    pts = circle.sample(64)
    assert np.array_equal(pts[0], pts[-1])
    d, s = circle.project(pts[:-1])
    assert d.max() < 1e-15 and np.all(np.diff(s) > 0)
    assert circle.project(np.array([[0.0, 0.0, 2.0]]))[0][0] == pytest.approx(np.hypot(1, 0.5))
    # The 64-gon's edges follow the circle all the way round (the last one wraps).
    n = 64
    rim = pts[:-1]
    fan = np.array([[0, i, i + 1] for i in range(1, n - 1)])
    cov = fm.crease_coverage(rim, fan, [circle], tol=1e-12)
    assert cov["coverage"] == pytest.approx(1.0, abs=1e-12)
    # One triangle far from vertex 0: its one rim edge covers 1/n of the circle.
    one = fm.crease_coverage(rim, np.array([[0, 30, 31]]), [circle], tol=1e-12)
    assert one["coverage"] == pytest.approx(1.0 / n, abs=1e-12)
    # Moved off the circle by 1e-6, nothing is on it at tol 1e-9.
    off = fm.crease_coverage(rim * (1 + 2e-6), fan, [circle], tol=1e-9)
    assert off["coverage"] == 0.0


@pytest.mark.parametrize("name", sorted(crease_shapes.SHAPES))
def test_crease_shape_curves_are_on_the_surface_and_on_two_pieces(name):
    import rdmesh

    shape = crease_shapes.SHAPES[name]()
    pts = np.concatenate([c.sample(32) for c in shape.curves])
    assert np.abs(shape.f(pts)).max() < 1e-15
    assert np.abs(shape.f(shape.corners)).max() < 1e-15 if len(shape.corners) else True
    surface = (
        shape.csg()
        if shape.csg is not None
        else rdmesh.ImplicitSurface.from_expression(shape.expression, shape.bounding_sphere)
    )
    x = np.random.default_rng(1).uniform(-1.6, 1.6, (2000, 3))
    assert np.abs(surface.f(x) - shape.f(x)).max() < 1e-14
    # Each curve point is a crease: just off it along the curve's normal plane,
    # f changes its gradient (two pieces meet at an angle).
    g = surface.grad(pts + 1e-7) - surface.grad(pts - 1e-7)
    assert (np.linalg.norm(g, axis=1) > 0.1).mean() > 0.5
    for poly in crease_shapes.polylines(shape.curves):
        assert np.abs(shape.f(poly)).max() < 1e-15


def test_surface_distance_and_hausdorff_of_a_grown_cube():
    v, f = _cube(levels=1, scale=1.001)
    sd = fm.surface_distance(v, f, cad_shapes.box_sdf)
    assert sd["max"] == pytest.approx(math.sqrt(3) * 1e-3, rel=1e-9)  # at the corners
    ref_v, ref_f = _cube(levels=0)
    h = fm.mesh_hausdorff(v, f, ref_v, ref_f, n_random=5000)
    assert h["two_sided"] == pytest.approx(math.sqrt(3) * 1e-3, rel=1e-6)
    assert h["from_reference"]["max"] == pytest.approx(1e-3, rel=1e-6)


def test_angles_away_from_the_creases():
    v, f = _cube(levels=2)
    a = fm.angles_away_from(v, f, cad_shapes.box_curves(), radius=0.4)
    assert a["min_angle"] == pytest.approx(45.0) and a["min_angle_away"] == pytest.approx(45.0)
    # Vertices at 0 and +-0.5 on a face are 0.5 or more from the edges: the
    # 8 triangles of each face's middle 2 x 2 squares.
    assert a["faces_away"] == 6 * 8
    # Move the face's middle vertex next to a neighbour: slivers away from
    # the creases, which the away minimum sees.
    k = int(np.flatnonzero(np.all(np.isclose(v, [0.0, 0.0, 1.0]), axis=1))[0])
    w = v.copy()
    w[k] = [0.4, 0.0, 1.0]
    b = fm.angles_away_from(w, f, cad_shapes.box_curves(), radius=0.4)
    assert b["min_angle_away"] == pytest.approx(b["min_angle"]) and b["min_angle"] < 20
    none = fm.angles_away_from(v, f, cad_shapes.box_curves(), radius=10.0)
    assert none["faces_away"] == 0 and none["min_angle_away"] is None


# ---------------------------------------------------------------------------
# The CAD shapes
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(cad_shapes.CAD_SHAPES))
def test_cad_shape_is_closed_with_its_genus_and_creases(name):
    s = cad_shapes.CAD_SHAPES[name]()
    m = trimesh.Trimesh(s.vertices, s.faces, process=False)
    assert m.is_watertight and m.is_winding_consistent and m.volume > 0
    topo = fm.topology(s.vertices, s.faces)
    assert topo["closed_manifold"] and topo["components"] == 1
    assert topo["genus"] == s.genus
    expected_genus = {"box": 0, "box_with_hole": 1, "l_bracket": 0, "fillet_chamfer": 0}
    assert s.genus == expected_genus[name]
    # The listed creases are exactly the edges whose normals differ by more
    # than SHARP_ANGLE, each once.
    sharp = {
        tuple(map(int, e)) for e in fm.sharp_edges(s.vertices, s.faces, cad_shapes.SHARP_ANGLE)
    }
    pairs = _segment_pairs(s, s.curves)
    assert sum(len(c) - 1 for c in s.curves) == len(pairs)
    assert pairs == sharp
    # Corners: the end points of the open curves.
    ends = {tuple(c[i]) for c in s.curves if not np.array_equal(c[0], c[-1]) for i in (0, -1)}
    assert ends == {tuple(p) for p in s.corners}
    if name != "box":
        assert np.linalg.norm(s.vertices, axis=1).max() == pytest.approx(1.0)


def test_cad_shape_details():
    hole = cad_shapes.box_with_hole()
    loops = [c for c in hole.curves if np.array_equal(c[0], c[-1])]
    assert len(loops) == 2 and all(len(c) == cad_shapes.HOLE_SIDES + 1 for c in loops)
    assert len(hole.curves) == 4 + 8 + 2 and len(hole.corners) == 8
    bracket = cad_shapes.l_bracket()
    assert len(bracket.curves) == 6 + 12 and len(bracket.corners) == 12
    fc = cad_shapes.fillet_chamfer()
    assert sorted(fc.angles)[:2] == pytest.approx([45.0, 45.0])
    assert len(fc.curves) == 4 + 8 and len(fc.corners) == 8
    # CGAL's rule at 60 degrees misses exactly the chamfer's two creases.
    at60 = {tuple(map(int, e)) for e in fm.sharp_edges(fc.vertices, fc.faces, 60.0)}
    assert at60 == _segment_pairs(fc, fc.curves_sharper_than(60.0))
    assert len(fc.curves_sharper_than(60.0)) == len(fc.curves) - 2
    # No crease on the fillet: its wall's vertical edges turn by 90/16 degrees.
    just_above = 90.0 / cad_shapes.FILLET_SEGMENTS + 0.1
    n_above = len(fm.sharp_edges(fc.vertices, fc.faces, just_above))
    assert n_above == len(fm.sharp_edges(fc.vertices, fc.faces, cad_shapes.SHARP_ANGLE))
    assert len(fm.sharp_edges(fc.vertices, fc.faces, just_above - 0.2)) > n_above


def test_box_ball_curves():
    curves = cad_shapes.box_ball_curves()
    assert len(curves) == 15
    lengths = sorted(c.length for c in curves)
    assert lengths[:3] == pytest.approx([1.2] * 3)
    assert lengths[3:6] == pytest.approx([0.4 * np.pi] * 3)
    assert lengths[6:] == pytest.approx([2.0] * 9)
    polylines = cad_shapes.curve_polylines(curves, arc_segments=64)
    ends = [tuple(p[i]) for p in polylines for i in (0, -1)]
    corners = {tuple(c) for c in cad_shapes.box_ball_corners()}
    assert set(ends) == corners and len(corners) == 10
    # Each corner ends exactly three curves (bit-equal end points).
    assert all(ends.count(c) == 3 for c in corners)
    # The curves lie on the surface, on the crease between two of its pieces.
    for c in curves:
        p = c.sample(50)
        assert np.abs(cad_shapes.box_ball_sdf(p)).max() < 1e-15
    for c in cad_shapes.box_curves():
        assert np.abs(cad_shapes.box_sdf(c.sample(10))).max() < 1e-15


# ---------------------------------------------------------------------------
# Polylines file, and the script's input rows
# ---------------------------------------------------------------------------


def test_write_polylines_round_trip(tmp_path):
    polylines = cad_shapes.curve_polylines(cad_shapes.box_ball_curves())
    loop = np.vstack([cad_shapes.box_with_hole().curves[-1]])
    path = tmp_path / "p.txt"
    cgal_runner.write_polylines(path, [*polylines, loop + 5.0])
    back = cgal_runner.read_polylines(path)
    assert len(back) == 16
    for a, b in zip([*polylines, loop + 5.0], back, strict=True):
        assert np.array_equal(np.asarray(a), np.asarray(b))  # 17 digits: exact
    first = path.read_text().splitlines()[0].split()
    assert first[0] == "2" and len(first) == 7


@pytest.mark.parametrize(
    "polylines, message",
    [
        ([[(0, 0, 0), (1, 0, 0), (2, 0, 0)], [(1, 0, 0), (1, 1, 0)]], "end points"),
        ([[(0, 0, 0), (0, 0, 0), (1, 0, 0)]], "equal"),
        ([[(0, 0, 0)]], "at least 2"),
        ([[(0, 0, 0), (float("nan"), 0, 0)]], "finite"),
        ([], "no polylines"),
    ],
)
def test_write_polylines_refuses(tmp_path, polylines, message):
    with pytest.raises(ValueError, match=message):
        cgal_runner.write_polylines(tmp_path / "p.txt", polylines)
    assert not (tmp_path / "p.txt").exists()


def test_features_script_on_its_input_rows(tmp_path):
    cmd = [sys.executable, str(BENCH / "features.py"), "--cases", "l_bracket", "box_with_hole"]
    cmd += ["--meshers", "input", "--out", str(tmp_path), "--hausdorff-samples", "2000"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr
    rows = [ln for ln in proc.stdout.splitlines() if ln.startswith("| l_bracket")]
    assert rows and "| 12 | 100.0 %" in rows[0]
    import json

    (path,) = tmp_path.glob("features-*.json")
    rec = json.loads(path.read_text())
    runs = {r["case"]: r for r in rec["runs"]}
    assert set(runs) == {"l_bracket", "box_with_hole"}
    hole = runs["box_with_hole"]["metrics"]
    assert hole["coverage"] == pytest.approx(1.0) and hole["topology"]["genus"] == 1
    assert hole["hausdorff"]["two_sided"] < 1e-12
    assert rec["cases"]["box_with_hole"]["radius"] == pytest.approx(0.02)


def test_features_script_finds_the_lens_circle(tmp_path):
    cmd = [sys.executable, str(BENCH / "features.py"), "--cases", "lens"]
    cmd += ["--meshers", "rdmesh_found", "--out", str(tmp_path)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr
    import json

    (path,) = tmp_path.glob("features-*.json")
    (run,) = json.loads(path.read_text())["runs"]
    assert run["status"] == "ok", run.get("error")
    assert run["info"]["found"]["curves"] == 1 and run["info"]["found"]["closed"] == 1
    m = run["metrics"]
    assert m["coverage"] == pytest.approx(1.0) and m["topology"]["euler"] == 2
    assert m["crease_vertices"]["count"] > 0 and m["crease_vertices"]["max_distance"] < 1e-12


# ---------------------------------------------------------------------------
# The CGAL reference's features modes (slow: builds it)
# ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def cgal_exe():
    try:
        return cgal_runner.build_reference()
    except cgal_runner.CgalReferenceError as exc:  # pragma: no cover - machine without CGAL
        pytest.fail(f"CGAL reference does not build: {exc}")


@pytest.mark.slow
def test_cgal_mesh_3_features_keeps_the_box_edges(cgal_exe, tmp_path):
    from meshfile import read_off

    pl, out = tmp_path / "box.txt", tmp_path / "box.off"
    cgal_runner.write_polylines(pl, cad_shapes.curve_polylines(cad_shapes.box_curves()))
    cmd = cgal_runner.features_command(cgal_exe, "box", pl, 0.1, 30, 0.1, 0.01, 1e-8, out=out)
    res = cgal_runner.run_command(cmd, timeout=600)
    assert res["closed"] and res["euler_characteristic"] == 2
    assert res["corner_vertices"] == 8 and res["domain_corners"] == 8
    assert res["domain_curves"] == 12 and res["feature_vertices"] > 100
    v, f = read_off(out)
    assert len(np.unique(f)) == res["vertices"]
    cov = fm.crease_coverage(v, f, cad_shapes.box_curves())
    assert cov["coverage"] == pytest.approx(1.0, abs=1e-9)
    cv = fm.crease_vertex_distance(v, cad_shapes.box_curves())
    assert cv["count"] == res["feature_vertices"] and cv["max_distance"] < 1e-12
    assert fm.surface_distance(v, f, cad_shapes.box_sdf)["max"] < 1e-6
    # Outward: positive volume.
    assert trimesh.Trimesh(v, f, process=False).volume > 0
    # A polyline sharing an interior point with another is refused (CGAL #7356).
    bad = tmp_path / "bad.txt"
    bad.write_text("3 -1 -1 -1 0 -1 -1 1 -1 -1\n2 0 -1 -1 0 -1 1\n")
    cmd = cgal_runner.features_command(cgal_exe, "box", bad, 0.1, 30, 0.1, 0.01)
    with pytest.raises(cgal_runner.CgalReferenceError, match="end points"):
        cgal_runner.run_command(cmd, timeout=60)


@pytest.mark.slow
def test_cgal_mesh_3_polyhedron_keeps_the_bracket_edges(cgal_exe, tmp_path):
    from meshfile import read_off

    s = cad_shapes.l_bracket()
    inp, out = tmp_path / "in.off", tmp_path / "out.off"
    cgal_runner.write_off(inp, s.vertices, s.faces)
    r = 0.03 * s.diagonal
    cmd = cgal_runner.polyhedron_command(cgal_exe, inp, 60, r, 30, r, r / 10, out=out)
    res = cgal_runner.run_command(cmd, timeout=600)
    assert res["domain_curves"] == 18 and res["domain_corners"] == 12
    assert res["error_bound"] is None and res["closed"]
    v, f = read_off(out)
    assert fm.crease_coverage(v, f, s.curves)["coverage"] == pytest.approx(1.0, abs=1e-9)
    assert fm.corner_hits(v, s.corners)["hit"] == 12
    assert fm.topology(v, f)["genus"] == 0
    h = fm.mesh_hausdorff(v, f, s.vertices, s.faces, n_random=20000)
    assert h["two_sided"] < 1e-9  # flat faces, creases kept: on the input
