"""Feature curves kept by protecting balls (issue 27): given polylines, clip
boundaries, a volume's box and a mesh's sharp edges; the feature check; bad
input. Every property is recomputed from the output arrays."""

from __future__ import annotations

import re

import numpy as np
import pytest
import rdmesh
from clipped_surfaces import plane
from meshcheck import boundary_edges, euler_per_component
from rdmesh.core import MeshDistance
from rdmesh.features import FeatureError
from rdmesh.refine.criteria import min_angles

CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
EDGES = [
    np.array([CORNERS[i], CORNERS[j]])
    for i in range(8)
    for j in range(i + 1, 8)
    if np.sum(CORNERS[i] != CORNERS[j]) == 1
]


def box(p):
    x, y, z = np.abs(p).T
    return np.maximum(np.maximum(x, y), z) - 1.0


def on_box_edge(p, tol=1e-12):
    """Points on an edge of the cube [-1, 1]^3: two coordinates at +-1."""
    return (np.abs(np.abs(p) - 1.0) <= tol).sum(axis=1) >= 2


def edge_coverage(m):
    """Share of the 12 edges' length (24) covered by mesh edges lying on them."""
    f = m.faces
    e = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1),
                  axis=0)  # fmt: skip
    a, b = m.vertices[e[:, 0]], m.vertices[e[:, 1]]
    on = on_box_edge(a) & on_box_edge(b) & on_box_edge(0.5 * (a + b))
    return float(np.linalg.norm(b - a, axis=1)[on].sum() / 24.0)


def surface_gap(m, f, n=12):
    """Largest |f| at points spread over every triangle."""
    w = np.random.default_rng(0).dirichlet([1, 1, 1], size=n)
    pts = np.einsum("kj,fjd->fkd", w, m.vertices[m.faces]).reshape(-1, 3)
    return float(np.abs(f(pts)).max())


@pytest.fixture(scope="module")
def protected_box():
    s = rdmesh.ImplicitSurface(box, ((0, 0, 0), 2.0), features=EDGES, name="box")
    return rdmesh.mesh_surface(s, radius_bound=0.1, distance_bound=0.01)


def test_a_box_with_its_edges_given_keeps_them_exactly(protected_box):
    m = protected_box
    assert m.complete
    assert m.features.held
    assert len(m.features.curves) == 12 and len(m.features.corners) == 8
    # Every corner is a vertex, every edge is covered by mesh edges on it.
    for c in CORNERS:
        assert np.linalg.norm(m.vertices - c, axis=1).min() == 0.0
    assert edge_coverage(m) == pytest.approx(1.0, abs=1e-12)
    # The balls' centres are the vertices on the edges, exactly there.
    balls = m.weights > 0
    assert np.array_equal(balls, on_box_edge(m.vertices, 1e-9))
    # No chamfer: every triangle lies in a face of the cube.
    assert surface_gap(m, box) <= 1e-12
    assert np.abs(box(m.vertices)).max() <= 1e-12
    assert m.is_closed_manifold() and euler_per_component(m.faces, len(m.vertices)) == [2]


def test_the_angle_bound_holds_away_from_the_balls(protected_box):
    m = protected_box
    at_ball = (m.weights > 0)[m.faces].any(axis=1)
    assert m.angles[~at_ball].min() >= 30.0 - 1e-9
    # Relaxed next to the balls, with a floor of 20 degrees (measured: 20.0
    # to 21.5 on the box; not proven).
    assert m.angles[at_ball].min() >= 20.0 - 1e-9
    # The size bound away from the balls.
    r = m.ball_radii
    assert r[~at_ball].max() <= 0.1 * (1 + 1e-9)


def test_without_features_the_box_is_chamfered():
    s = rdmesh.ImplicitSurface(box, ((0, 0, 0), 2.0), features="none")
    m = rdmesh.mesh_surface(s, radius_bound=0.1, distance_bound=0.01)
    assert m.features is None and m.weights is None
    assert edge_coverage(m) < 0.05
    assert surface_gap(m, box) > 1e-3


def test_the_same_seed_gives_the_same_protected_mesh(protected_box):
    s = rdmesh.ImplicitSurface(box, ((0, 0, 0), 2.0), features=EDGES)
    m = rdmesh.mesh_surface(s, radius_bound=0.1, distance_bound=0.01)
    assert np.array_equal(m.vertices, protected_box.vertices)
    assert np.array_equal(m.faces, protected_box.faces)


def test_the_report_and_summary_say_what_was_kept(protected_box):
    rep = protected_box.report["features"]
    assert rep["held"] is True and rep["level"] == "proven"
    assert rep["edges_kept"] == rep["edges"] > 0 and rep["corners_kept"] == 8
    assert rep["sources"] == ["given"]
    assert "features: 12 curves, 8 corners kept" in protected_box.summary()


def test_edge_size_sets_the_spacing_along_the_curves():
    s = rdmesh.ImplicitSurface(box, ((0, 0, 0), 2.0), features=EDGES)
    m = rdmesh.mesh_surface(s, radius_bound=0.15, distance_bound=0.02, edge_size=0.07)
    assert m.features.held
    f = m.faces
    e = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1),
                  axis=0)  # fmt: skip
    a, b = m.vertices[e[:, 0]], m.vertices[e[:, 1]]
    on = on_box_edge(a) & on_box_edge(b) & on_box_edge(0.5 * (a + b))
    length = np.linalg.norm(b - a, axis=1)[on]
    assert length.max() <= 0.07 * (1 + 1e-9)
    assert length.sum() == pytest.approx(24.0, rel=1e-9)


def test_a_closed_loop_given_by_repeating_its_first_point():
    """A cylinder's rims, each a closed polyline (64 chords of the circle)."""

    def cylinder(p):
        x, y, z = p.T
        return np.maximum(np.hypot(x, y) - 0.8, np.abs(z) - 0.6)

    t = np.linspace(0, 2 * np.pi, 65)
    rims = [np.c_[0.8 * np.cos(t), 0.8 * np.sin(t), np.full(65, h)] for h in (-0.6, 0.6)]
    rims[0][-1] = rims[0][0]  # exactly closed
    s = rdmesh.ImplicitSurface(cylinder, ((0, 0, 0), 1.5), features=rims)
    m = rdmesh.mesh_surface(s, radius_bound=0.1, distance_bound=0.01)
    assert m.features.held and len(m.features.curves) == 2
    assert all(c[0] == c[-1] for c in m.features.curves)  # loops
    assert len(m.features.corners) == 0
    assert m.is_closed_manifold() and euler_per_component(m.faces, len(m.vertices)) == [2]


def test_curves_meeting_at_an_end_on_another_curve_split_it():
    """Two box edges given as one polyline through a corner, plus an edge
    ending at that corner: the polyline is split there (a T-junction)."""
    c = CORNERS
    through = np.array([c[0], c[1], c[3]])  # two edges turning at c[1]
    rest = [e for e in EDGES if not (
        {tuple(e[0]), tuple(e[1])} <= {tuple(c[0]), tuple(c[1])}
        or {tuple(e[0]), tuple(e[1])} <= {tuple(c[1]), tuple(c[3])}
    )]  # fmt: skip
    s = rdmesh.ImplicitSurface(box, ((0, 0, 0), 2.0), features=[through, *rest])
    m = rdmesh.mesh_surface(s, radius_bound=0.15, distance_bound=0.02)
    assert m.features.held
    assert len(m.features.curves) == 12 and len(m.features.corners) == 8


@pytest.mark.parametrize(
    "features, match",
    [
        ([np.array([[0.0, 0.0, 1.0], [np.nan, 0.0, 1.0]])], r"features\[0\] has a non-finite"),
        ([np.array([[0.0, 0.0, 1.0]])], r"features\[0\] has 1 point"),
        ([np.array([[1.0, 1.0, 1.0], [1.0, 1.0, 1.0]])], r"features\[0\] has fewer than two"),
        ([np.zeros((3, 2))], r"features\[0\] must have shape \(m, 3\)"),
        ([[["a", "b", "c"], [1, 2, 3]]], r"features\[0\] is not an array of numbers"),
        (np.zeros((4, 3)), "wrap it in a list"),
        (42, "list of"),
        ("some", "features must be"),
        # Two face diagonals of the top face cross at its centre.
        (
            [np.array([[-1.0, -1, 1], [1, 1, 1]]), np.array([[-1.0, 1, 1], [1, -1, 1]])],
            r"features\[0\] and features\[1\] cross",
        ),
        ([np.array([[-1.0, -1, 1], [1, 1, 1], [1, -1, 1], [-1, 1, 1]])], "crosses itself"),
    ],
)
def test_bad_feature_curves_are_refused_when_the_surface_is_made(features, match):
    with pytest.raises(FeatureError, match=match):
        rdmesh.ImplicitSurface(box, ((0, 0, 0), 2.0), features=features)


def test_a_curve_off_the_surface_is_refused_when_meshing():
    s = rdmesh.ImplicitSurface(
        box, ((0, 0, 0), 2.0), features=[np.array([[0, 0, 0.5], [1, 1, 1]])]
    )
    with pytest.raises(FeatureError, match=r"features\[0\] is not on the surface"):
        rdmesh.mesh_surface(s, radius_bound=0.2)


def test_feature_error_is_a_value_error_and_exported():
    assert issubclass(rdmesh.FeatureError, ValueError)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"method": "topological-ball"}, "boissonnat-oudot"),
        ({"edge_size": 0.0}, "edge_size must be a positive number"),
        ({"edge_size": -1.0}, "edge_size must be a positive number"),
    ],
)
def test_bad_options_with_features(kwargs, match):
    s = rdmesh.ImplicitSurface(box, ((0, 0, 0), 2.0), features=EDGES)
    with pytest.raises(ValueError, match=match):
        rdmesh.mesh_surface(s, radius_bound=0.2, **kwargs)


def test_a_ball_cut_by_its_volume_box_keeps_the_circles():
    n = 32
    g = np.linspace(-1, 1, n)
    x, y, z = np.meshgrid(g, g, g, indexing="ij")
    vol = 1.3 - np.sqrt(x**2 + y**2 + z**2)
    s = rdmesh.VolumeSurface(vol, spacing=(2 / (n - 1),) * 3, origin=(-1, -1, -1), isovalue=0.0)
    m = rdmesh.mesh_surface(s, radius_bound=0.1, distance_bound=0.01)
    assert m.complete and m.features.held
    assert m.report["features"]["sources"] == ["volume box"]
    assert len(m.features.curves) == 6
    assert m.is_closed_manifold() and euler_per_component(m.faces, len(m.vertices)) == [2]
    # Each circle's edges: on a face and on the isosurface, joined in a loop.
    v = m.vertices
    for c in m.features.curves:
        assert c[0] == c[-1] and (c >= 0).all()
        on_face = (np.abs(np.abs(v[c]) - 1.0) <= 1e-12).any(axis=1)
        assert on_face.all()
        assert np.abs(s.f_volume(v[c])).max() <= 1e-9


def test_a_cube_mesh_is_remeshed_with_its_edges_and_corners():
    tri = np.array([
        [0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
        [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3],
    ])  # fmt: skip
    s = rdmesh.MeshSurface((CORNERS, tri))
    assert len(s.sharp_edges) == 12 and len(s.sharp_curves) == 12
    m = rdmesh.mesh_surface(s, radius_bound=0.2, distance_bound=0.02)
    assert m.features.held and m.report["features"]["sources"] == ["mesh"]
    assert edge_coverage(m) == pytest.approx(1.0, abs=1e-12)
    assert m.is_closed_manifold() and euler_per_component(m.faces, len(m.vertices)) == [2]
    plain = rdmesh.MeshSurface((CORNERS, tri), feature_angle=None)
    assert len(plain.sharp_edges) == 0


@pytest.mark.parametrize("angle", [0.0, 180.0, -5.0, "x", True])
def test_a_bad_feature_angle_is_refused(angle):
    tri = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                    [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])  # fmt: skip
    with pytest.raises(ValueError, match="feature_angle"):
        rdmesh.MeshSurface((CORNERS, tri), feature_angle=angle)


def test_a_clipped_plane_has_its_boundary_protected():
    s = rdmesh.ImplicitSurface(plane, ((0, 0, 0), 1.0))
    m = rdmesh.mesh_surface(s, topology="manifold-with-boundary", radius_bound=0.1)
    assert m.features.held and m.report["features"]["sources"] == ["clip boundary"]
    edges, bv = boundary_edges(m.faces)
    assert len(edges) == m.features.edges
    # Boundary vertices are the balls' centres, on the sphere and the plane.
    assert np.array_equal(np.unique(bv), np.flatnonzero(m.weights > 0))
    assert np.abs(np.linalg.norm(m.vertices[bv], axis=1) - 1).max() <= 1e-12
    assert min_angles(m.vertices[m.faces]).min() >= 20.0
    assert m.topology()["euler"] == [1] and m.report["boundary"]["loops_match"]


def test_curves_rdmesh_cannot_protect_are_left_out_and_reported(caplog):
    # On the box face z = 0 the clip boundary is x y = 1e-14: two branches
    # 2e-7 apart at the origin, closer than the smallest ball.
    def saddle(p):
        return p[:, 0] * p[:, 1] - 1e-14 + 0.3 * p[:, 2]

    box = np.array([[-1.0, -1.0, 0.0], [1.0, 1.0, 1.0]])
    s = rdmesh.ImplicitSurface(saddle, ((0, 0, 0), 1.8), clip_box=box)
    with caplog.at_level("WARNING", logger="rdmesh"):
        m = rdmesh.mesh_surface(s, topology="manifold-with-boundary", radius_bound=0.1)
    f = m.report["features"]
    assert f["held"] is False and "smaller than" in f["abandoned"]
    assert m.features is None and not m.complete
    assert m.stats["stop_reason"].startswith("feature curves not protected")
    assert "not protected" in caplog.text
    # Still the whole surface: one disk-like sheet meeting the box.
    assert len(m.faces) > 100 and np.abs(saddle(m.vertices)).max() < 1e-6
    # Given curves that cannot be protected are an error, not left out.
    # Two level curves of the sheet 1e-7 apart.
    x = np.linspace(0.3, 0.6, 50)
    close = [np.c_[x, (1e-14 - 0.3 * z) / x, np.full_like(x, z)] for z in (0.5, 0.5 + 1e-7)]
    with pytest.raises(FeatureError):
        given = rdmesh.ImplicitSurface(saddle, ((0, 0, 0), 1.8), clip_box=box, features=close)
        rdmesh.mesh_surface(given, topology="manifold-with-boundary", radius_bound=0.1)


def test_crossings_are_found_beside_a_long_segment():
    from rdmesh.features.graph import build_graph, curve_of_polyline

    # One long straight segment (a box edge) and a dense circle around it:
    # the proximity search must not widen to every pair, and must still see
    # a crossing of the segment with the circle.
    t = np.linspace(0, 2 * np.pi, 20001)
    ring = np.c_[np.cos(t), np.sin(t), np.zeros_like(t)]
    ring[-1] = ring[0]
    apart = [np.array([[-5.0, 0, 1.0], [5.0, 0, 1.0]]), ring]
    graph = build_graph(
        [curve_of_polyline(p, 5.0, f"c{k}", "given") for k, p in enumerate(apart)], 5.0
    )
    assert len(graph.curves) == 2
    crossing = [np.array([[-5.0, 0, 0], [5.0, 0, 0]]), ring]
    with pytest.raises(FeatureError, match="cross"):
        build_graph(
            [curve_of_polyline(p, 5.0, f"c{k}", "given") for k, p in enumerate(crossing)], 5.0
        )


# -- the command line ---------------------------------------------------------------------


def _write_polylines(path, polylines):
    with open(path, "w", encoding="utf-8") as fh:
        for p in polylines:
            fh.write(f"{len(p)} " + " ".join(f"{x:.17g}" for x in np.ravel(p)) + "\n")


def test_cli_mesh_keeps_the_curves_of_a_polylines_file(tmp_path, capsys):
    from rdmesh import cli

    feats = tmp_path / "edges.polylines.txt"
    _write_polylines(feats, EDGES)
    out = tmp_path / "box.ply"
    expr = "max(max(abs(x), abs(y)), abs(z)) - 1"
    status = cli.main(["mesh", expr, "--bound", "2", "-o", str(out), "--radius", "0.15",
                       "--distance", "0.02", "--features", str(feats), "--quiet"])  # fmt: skip
    text = capsys.readouterr().out
    assert status == 0
    assert "features: 12 curves, 8 corners kept" in text
    import trimesh

    tm = trimesh.load(out, process=False)
    assert tm.is_watertight
    for c in CORNERS:
        assert np.linalg.norm(tm.vertices - c, axis=1).min() <= 1e-12


@pytest.mark.parametrize(
    "content, match",
    [
        ("2 0 0 1 1 1\n", "line 1: a polyline of 2 points needs 6 numbers"),
        ("x 0 0 1\n", "line 1: expected a count"),
        ("", "holds no polyline"),
        ("2 0 0 0.5 1 1 1\n", r"features\[0\] is not on the surface"),
    ],
)
def test_cli_bad_polylines_file_is_a_one_line_error(tmp_path, capsys, content, match):
    from rdmesh import cli

    feats = tmp_path / "bad.txt"
    feats.write_text(content, encoding="utf-8")
    status = cli.main(["mesh", "max(max(abs(x), abs(y)), abs(z)) - 1", "--bound", "2", "-o",
                       str(tmp_path / "o.ply"), "--features", str(feats), "--quiet"])  # fmt: skip
    err = capsys.readouterr().err
    assert status == 2
    assert len(err.strip().splitlines()) == 1 and re.search(match, err)


def test_cli_remesh_keeps_a_cubes_corners_unless_told_not_to(tmp_path, capsys):
    import trimesh
    from rdmesh import cli

    tri = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                    [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])  # fmt: skip
    src = tmp_path / "cube.ply"
    trimesh.Trimesh(CORNERS, tri, process=False).export(src)
    for extra, kept in (([], True), (["--feature-angle", "0"], False)):
        out = tmp_path / "out.ply"
        status = cli.main(["remesh", str(src), "-o", str(out), "--radius", "0.25",
                           "--distance", "0.03", "--quiet", *extra])  # fmt: skip
        text = capsys.readouterr().out
        assert status == 0
        assert ("features: 12 curves, 8 corners kept" in text) is kept
        got = trimesh.load(out, process=False)
        hit = [np.linalg.norm(got.vertices - c, axis=1).min() <= 1e-9 for c in CORNERS]
        if kept:
            assert all(hit)
        else:
            # Not protected, but the distance check brings the corners within
            # the distance bound of the output.
            d = MeshDistance(got.vertices, got.faces, side=False).query(CORNERS)[0]
            assert d.max() <= 0.03


def test_auto_feature_angle_leaves_out_noise(caplog):
    """A noisy marching-cubes torus: the many short sharp chains are noise."""
    from skimage import measure

    n, lo, hi = 30, -1.6, 1.6
    axis = np.linspace(lo, hi, n)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    values = (x * x + y * y + z * z + 1 - 0.16) ** 2 - 4 * (x * x + y * y)
    step = (hi - lo) / (n - 1)
    verts, faces, _, _ = measure.marching_cubes(values, 0.0, spacing=(step,) * 3)
    verts = verts + lo + np.random.default_rng(0).normal(scale=0.15 * step, size=verts.shape)
    explicit = rdmesh.MeshSurface((verts, faces), feature_angle=60)
    assert len(explicit.sharp_curves) > 50
    with caplog.at_level("WARNING", logger="rdmesh"):
        auto = rdmesh.MeshSurface((verts, faces))
    assert len(auto.sharp_edges) == 0 and auto.sharp_curves == []
    assert "look like noise" in caplog.text


def test_auto_feature_angle_leaves_out_roughness(caplog):
    """A coarse, bumpy sphere: its sharpest edges are the tail of a spread of
    dihedral angles, not creases; a cube's edges stand apart and are kept."""
    import trimesh
    from rdmesh.features.sharp_edges import ROUGH_RATIO

    m = trimesh.creation.icosphere(subdivisions=3)
    u = np.asarray(m.vertices)
    theta, phi = np.arccos(u[:, 2]), np.arctan2(u[:, 1], u[:, 0])
    verts = u * (1 + 0.3 * np.sin(4 * theta) * np.cos(4 * phi))[:, None]
    faces = np.asarray(m.faces)
    explicit = rdmesh.MeshSurface((verts, faces), feature_angle=60)
    assert len(explicit.sharp_curves) >= 4
    # The rule's premise on this input: many more edges 30-60 degrees than 60 or more.
    angles = np.degrees(trimesh.Trimesh(verts, faces, process=False).face_adjacency_angles)
    near, sharp = np.count_nonzero((angles >= 30) & (angles < 60)), np.count_nonzero(angles >= 60)
    assert near > ROUGH_RATIO * sharp > 0
    with caplog.at_level("WARNING", logger="rdmesh"):
        auto = rdmesh.MeshSurface((verts, faces))
    assert len(auto.sharp_edges) == 0 and auto.sharp_curves == []
    assert "roughness" in caplog.text
    cube = trimesh.creation.box(extents=(2.0, 2.0, 2.0))
    assert len(rdmesh.MeshSurface((cube.vertices, cube.faces)).sharp_curves) == 12
