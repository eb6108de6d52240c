"""Any surface clipped to a box: ``ImplicitSurface(..., clip_box=...)``.

Expression and numpy surfaces meshed only inside an axis-aligned box, with a
boundary on its faces (``topology="manifold-with-boundary"``, the default for
them). Every property is recomputed from the vertex and face arrays
(``meshcheck``) or from ``f`` itself, not read from the library's report.

Tolerances:

- on a box face, ``1e-12`` times the box size: a boundary vertex's face
  coordinate is set to the face's value, not computed, so only rounding is
  left (the runs below measured 0);
- on the surface, ``|f| / |grad f| <= 1e-8 R``: interior vertices are roots
  along dual segments or seeding shots, found to ``1e-10 R`` and ``1e-9 R``
  (``rdmesh._tol``), boundary vertices Newton projections (measured: 1.4e-9,
  that is 2e-10 R, on the gyroid). This is also below a millionth of the
  distance bound.
"""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
from meshcheck import (
    boundary_edges,
    boundary_loop_count,
    circumcentre_ref,
    distance_to_surface,
    edge_counts,
    euler_per_component,
    manifold_with_boundary_problems,
)
from rdmesh import cli
from scipy.optimize import brentq

GYROID = "sin(x)*cos(y) + sin(y)*cos(z) + sin(z)*cos(x)"
#: A cube of side 6.6 (a period is 2 pi), off the gyroid's symmetry centre so
#: that the curve crosses the box edges transversally, away from corners.
CUBE = np.array([[0.3, -0.2, 0.1]]) + np.array([[-3.3] * 3, [3.3] * 3])
#: About 1,400 vertices in about 3 s on the 2-core test machine. Both bounds
#: bind here: without the angle bound the smallest interior angle was 26.9
#: degrees, without the distance bound the largest distance 0.044.
SIZE, DISTANCE = 0.3, 0.02


def gyroid(p: np.ndarray) -> np.ndarray:
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    return np.sin(x) * np.cos(y) + np.sin(y) * np.cos(z) + np.sin(z) * np.cos(x)


def sphere_about(box: np.ndarray) -> tuple[np.ndarray, float]:
    """The box's circumscribed sphere, enlarged by 10% (as the command line's)."""
    box = np.asarray(box, dtype=float)
    return box.mean(axis=0), 1.1 * 0.5 * float(np.linalg.norm(box[1] - box[0]))


def on_faces(x: np.ndarray, box: np.ndarray) -> np.ndarray:
    """(N, 6) which box faces (lo x y z, hi x y z) each point lies on."""
    tol = 1e-12 * float(np.max(box[1] - box[0]))
    return np.concatenate([np.abs(x - box[0]), np.abs(box[1] - x)], axis=1) <= tol


def _along(f, start: np.ndarray, axis: int):
    """``f`` along the line through ``start`` parallel to ``axis``, as a scalar function."""

    def g(t: float) -> float:
        q = start.copy()
        q[axis] = t
        return float(f(q[None])[0])

    return g


def box_edge_crossings(f, box: np.ndarray, n: int = 4001) -> np.ndarray:
    """Where ``f = 0`` crosses the 12 box edges, by sampling and brentq, ``(k, 3)``."""
    out = []
    for axis in range(3):
        a, b = [k for k in range(3) if k != axis]
        for ca in box[:, a]:
            for cb in box[:, b]:
                t = np.linspace(box[0, axis], box[1, axis], n)
                p = np.zeros((n, 3))
                p[:, axis], p[:, a], p[:, b] = t, ca, cb
                v = f(p)
                assert np.all(v != 0.0)  # no root on a sample: each is a clean bracket
                for i in np.flatnonzero(np.sign(v[1:]) != np.sign(v[:-1])):
                    q = p[i].copy()
                    q[axis] = brentq(_along(f, p[i], axis), t[i], t[i + 1], xtol=1e-14)
                    out.append(q)
    return np.array(out).reshape(-1, 3)


def check_clipped(s: rdmesh.ImplicitSurface, m: rdmesh.SurfaceMesh, size, distance) -> dict:
    """What every mesh of a surface clipped to a box satisfies; returns measured figures.

    ``size`` is the radius bound (a number or a sizing field), ``distance``
    the distance bound or None.
    """
    box, R = s.clip_box, s.radius
    v, F, C = m.vertices, m.faces, m.facet_centres
    assert m.complete, m.stats.get("stop_reason")
    assert m.stats["topology"] == "manifold-with-boundary"
    # A consistently oriented manifold with a boundary, checked from the faces.
    assert manifold_with_boundary_problems(F, len(v)) == []
    assert np.array_equal(np.unique(F), np.arange(len(v)))
    # chi = 2 - 2g - b per component with a whole genus g >= 0, b >= 1 (the
    # box cuts every component: a closed one inside it would have b = 0).
    loops = boundary_loop_count(F)
    chis = euler_per_component(F, len(v))
    twice_genus = 2 * len(chis) - sum(chis) - loops
    assert twice_genus >= 0 and twice_genus % 2 == 0
    chi = sum(chis)
    # Every vertex in the box, and on the surface; so are the surface centres.
    tol = 1e-12 * float(np.max(box[1] - box[0]))
    assert np.all(v >= box[0] - tol) and np.all(v <= box[1] + tol)
    dist = distance_to_surface(s, s.grad, v)
    assert dist.max() <= 1e-8 * R
    assert distance_to_surface(s, s.grad, C).max() <= 1e-8 * R
    # Boundary vertices on a box face; each boundary edge runs in one face.
    edges, bv = boundary_edges(F)
    on = on_faces(v, box)
    assert on[bv].any(axis=1).all()
    common = on[edges[:, 0]] & on[edges[:, 1]]
    assert common.any(axis=1).all()
    # Where the curve crosses a box edge there is a boundary vertex, and the
    # only vertices on two faces are those.
    crossings = box_edge_crossings(s, box)
    for q in crossings:
        assert np.linalg.norm(v[bv] - q, axis=1).min() <= 1e-9 * R
    assert int((on.sum(axis=1) >= 2).sum()) == len(crossings)
    # The boundary curve is protected: every boundary edge joins consecutive
    # balls, and triangles with a ball centre get Mesh_3's relaxation.
    assert m.features is not None and m.features.held
    assert len(edges) == m.features.edges
    exempt = (m.weights > 0)[F].any(axis=1)
    # Size bound: every surface Delaunay ball (centre C, through the corners)
    # of a triangle without a ball centre.
    r = np.linalg.norm(C[:, None, :] - v[F], axis=2).max(axis=1)
    bound = size(C) if callable(size) else np.full(len(C), float(size))
    assert np.all(r[~exempt] <= bound[~exempt] * (1 + 1e-9))
    # The angle bound away from the balls; 20 degrees (measured) next to them.
    assert m.angles[~exempt].min() >= 30.0 - 1e-9
    assert m.angles[exempt].min() >= 20.0
    if distance is not None:
        # Circumcentre to surface centre (away from the balls), and each
        # boundary chord's midpoint to the curve (|f| over the gradient
        # within the edge's face).
        gap = np.linalg.norm(circumcentre_ref(v[F]) - C, axis=1)[~exempt]
        assert gap.max() <= distance * (1 + 1e-9)
        mid = 0.5 * (v[edges[:, 0]] + v[edges[:, 1]])
        g = s.grad(mid)
        g[np.arange(len(g)), np.argmax(common, axis=1) % 3] = 0.0
        assert (np.abs(s(mid)) / np.linalg.norm(g, axis=1)).max() <= distance
    # The report: a box domain, sampled, nothing certified.
    rep = m.report
    assert rep["certified"] is False and m.topology_certified is False
    bd = rep["boundary"]
    assert bd["domain"] == "box" and bd["mesh_loops"] == loops
    assert bd["edge_crossings"] == len(crossings)
    assert "clip box" in rep["statement"] and "nothing is certified" in rep["statement"]
    return {
        "chi": chi,
        "loops": loops,
        "components": len(chis),
        "max_distance": float(dist.max()),
        "exempt_min_angle": float(m.angles[exempt].min()),
    }


@pytest.fixture(scope="module")
def gyroid_cube():
    s = rdmesh.ImplicitSurface.from_expression(GYROID, sphere_about(CUBE), clip_box=CUBE)
    m = rdmesh.mesh_surface(s, radius_bound=SIZE, distance_bound=DISTANCE)
    return s, m


def test_a_gyroid_clipped_to_a_cube_is_a_manifold_with_boundary_on_the_faces(gyroid_cube):
    s, m = gyroid_cube
    got = check_clipped(s, m, SIZE, DISTANCE)
    assert got["max_distance"] <= 1e-6 * DISTANCE
    # The default topology for a clip box; the boundary is on all six faces.
    assert m.is_manifold_with_boundary() and not m.is_closed_manifold()
    _, bv = boundary_edges(m.faces)
    assert on_faces(m.vertices[bv], CUBE).any(axis=0).all()
    # The cube is wider than a period: some component has a handle.
    assert got["chi"] < got["components"]


def test_a_numpy_gyroid_with_a_clip_box_meshes_the_same(gyroid_cube):
    s_expr, m_expr = gyroid_cube
    # No gradient: central differences.
    s = rdmesh.ImplicitSurface(gyroid, sphere_about(CUBE), name="numpy gyroid", clip_box=CUBE)
    m = rdmesh.mesh_surface(s, radius_bound=SIZE, distance_bound=DISTANCE)
    got = check_clipped(s, m, SIZE, DISTANCE)
    # The same surface: the same topology as the expression's mesh.
    assert sorted(m.topology()["euler"]) == sorted(m_expr.topology()["euler"])
    assert got["loops"] == boundary_loop_count(m_expr.faces)
    assert m.report["boundary"]["edge_crossings"] == m_expr.report["boundary"]["edge_crossings"]


#: A box around part of the plane z = 0.1.
PLANE_BOX = np.array([[-0.5, -0.4, -0.3], [0.6, 0.7, 0.5]])


def test_a_plane_clipped_by_a_box_is_the_rectangle():
    s = rdmesh.ImplicitSurface.from_expression(
        "z - 0.1", sphere_about(PLANE_BOX), clip_box=PLANE_BOX
    )
    m = rdmesh.mesh_surface(s, radius_bound=0.1)
    got = check_clipped(s, m, 0.1, None)
    assert (got["components"], got["chi"], got["loops"]) == (1, 1, 1)  # a disk
    v = m.vertices
    np.testing.assert_allclose(v[:, 2], 0.1, atol=1e-12)
    # Its boundary is the rectangle where z = 0.1 meets the four side faces:
    # a vertex at each corner, every boundary vertex on a side face, the
    # boundary as long as the rectangle's perimeter and the mesh as large.
    edges, bv = boundary_edges(m.faces)
    on = on_faces(v[bv], PLANE_BOX)
    assert on[:, [0, 1, 3, 4]].any(axis=1).all() and not on[:, [2, 5]].any()
    (x0, y0, _), (x1, y1, _) = PLANE_BOX
    for corner in [(x0, y0), (x0, y1), (x1, y0), (x1, y1)]:
        assert np.linalg.norm(v[bv] - [*corner, 0.1], axis=1).min() <= 1e-12
    length = np.linalg.norm(v[edges[:, 0]] - v[edges[:, 1]], axis=1)
    assert length.sum() == pytest.approx(2 * ((x1 - x0) + (y1 - y0)), rel=1e-12)
    assert length.max() <= 0.1 * (1 + 1e-9)
    area = 0.5 * np.linalg.norm(
        np.cross(v[m.faces[:, 1]] - v[m.faces[:, 0]], v[m.faces[:, 2]] - v[m.faces[:, 0]]),
        axis=1,
    )
    assert area.sum() == pytest.approx((x1 - x0) * (y1 - y0), rel=1e-12)


def test_a_sizing_field_sets_the_edge_lengths_on_a_clipped_surface():
    """A field growing fivefold from the box's lowest x face to its highest:
    the edges there follow it."""
    s = rdmesh.ImplicitSurface.from_expression(
        "z - 0.1", sphere_about(PLANE_BOX), clip_box=PLANE_BOX
    )
    (x0, _, _), (x1, _, _) = PLANE_BOX

    def field(p):
        return 0.03 + 0.12 * np.clip((p[:, 0] - x0) / (x1 - x0), 0.0, 1.0)

    m = rdmesh.mesh_surface(s, radius_bound=field)
    check_clipped(s, m, field, None)  # every ball within the field at its centre
    v, F = m.vertices, m.faces
    e = edge_counts(F)[0]
    length = np.linalg.norm(v[e[:, 0]] - v[e[:, 1]], axis=1)
    mid = 0.5 * (v[e[:, 0]] + v[e[:, 1]])
    fine, coarse = mid[:, 0] < x0 + 0.2, mid[:, 0] > x1 - 0.2
    # An edge is a chord of a ball within the field (measured: medians 0.047
    # and 0.12; a constant bound gives equal medians).
    assert length[fine].max() <= 2 * field(np.array([[x0 + 0.3, 0, 0]]))[0]
    assert np.median(length[coarse]) >= 2 * np.median(length[fine])
    # Boundary chords too: at most the field at their midpoint.
    edges, _ = boundary_edges(F)
    a, b = v[edges[:, 0]], v[edges[:, 1]]
    assert np.all(np.linalg.norm(a - b, axis=1) <= field(0.5 * (a + b)) * (1 + 1e-9))


# -- what is refused ----------------------------------------------------------------

SPHERE = ((0.0, 0.0, 0.0), 2.0)

BAD_BOXES = [
    ([0.0, 0.0, 0.0], r"shape \(2, 3\).*got shape \(3,\)"),
    ([[0, 0], [1, 1]], r"shape \(2, 3\).*got shape \(2, 2\)"),
    ([[0, 0, 0], [1, 1, 1], [2, 2, 2]], r"shape \(2, 3\).*got shape \(3, 3\)"),
    ([[0, 0, 0], [1, 1]], r"\(2, 3\) array"),
    ([[0, 0, np.nan], [1, 1, 1]], r"must be finite"),
    ([[0, 0, 0], [1, np.inf, 1]], r"must be finite"),
    ([[0, 0, 0], [1, 0, 1]], r"lo < hi on every axis.*not on y"),
    ([[1, 0, 1], [0, 1, 0]], r"lo < hi on every axis.*not on x, z"),
    ([[-1.2, -1.2, -1.2], [1.2, 1.2, 1.2]], r"must lie inside its bounding sphere"),
    ([[0, 0, 0], [2, 0.1, 0.1]], r"must lie inside its bounding sphere"),
    ([["a", "b", "c"], ["d", "e", "f"]], r"real numbers"),
    ([[True] * 3, [True] * 3], r"real numbers"),
]


@pytest.mark.parametrize(("box", "match"), BAD_BOXES, ids=[m for _, m in BAD_BOXES])
def test_bad_clip_boxes_are_refused_when_the_surface_is_made(box, match):
    with pytest.raises(ValueError, match=match):
        rdmesh.ImplicitSurface(gyroid, SPHERE, clip_box=box)
    with pytest.raises(ValueError, match=match):
        rdmesh.ImplicitSurface.from_expression(GYROID, SPHERE, clip_box=box)


def test_a_clip_box_reassigned_afterwards_is_checked_by_mesh_surface():
    s = rdmesh.ImplicitSurface.from_expression("z - 0.1", SPHERE, clip_box=[(-1,) * 3, (1,) * 3])
    assert isinstance(s.clip_box, np.ndarray) and s.clip_box.dtype == np.float64
    s.clip_box = np.array([[0.0, 0.0], [1.0, 1.0]])
    with pytest.raises(ValueError, match=r"shape \(2, 3\)"):
        rdmesh.mesh_surface(s)
    s.clip_box = np.array([[-1.0, -1.0, -1.0], [1.5, 1.5, 1.5]])
    with pytest.raises(ValueError, match="must lie inside its bounding sphere"):
        rdmesh.mesh_surface(s)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"topology": "manifold"}, r"topology 'manifold' .*clipped to a box.*clip_box=None"),
        ({"topology": "non-manifold"}, r"topology 'non-manifold' .*clip_box=None"),
        (
            {"method": "topological-ball"},
            r"method 'topological-ball' .*method='boissonnat-oudot'.*clip_box=None",
        ),
        ({"certify": True}, r"certify=True is not available"),
    ],
)
def test_incompatible_options_are_refused_with_the_fix(kwargs, match):
    s = rdmesh.ImplicitSurface.from_expression("z - 0.1", SPHERE, clip_box=[(-1,) * 3, (1,) * 3])
    with pytest.raises(ValueError, match=match):
        rdmesh.mesh_surface(s, **kwargs)


def test_without_a_clip_box_nothing_changes():
    s = rdmesh.ImplicitSurface.from_expression("x**2 + y**2 + z**2 - 1", SPHERE)
    assert s.clip_box is None
    m = rdmesh.mesh_surface(s, radius_bound=0.3)
    assert m.is_closed_manifold() and m.report["boundary"] is None


# -- command line -------------------------------------------------------------------


def test_cli_clips_an_expression_to_a_box(tmp_path, capsys):
    import trimesh

    out = tmp_path / "disk.ply"
    status = cli.main(
        ["mesh", "z - 0.1", "--clip-box", *map(str, PLANE_BOX.ravel()), "--radius", "0.1",
         "-o", str(out), "--quiet"]
    )  # fmt: skip
    captured = capsys.readouterr()
    assert status == 0, captured.err
    assert "boundary loops 1" in captured.out and "leaves its clip box" in captured.out
    tm = trimesh.load(out, process=False)
    assert not tm.is_watertight and tm.euler_number == 1
    np.testing.assert_allclose(tm.bounds[:, :2], PLANE_BOX[:, :2], atol=1e-12)
    np.testing.assert_allclose(tm.vertices[:, 2], 0.1, atol=1e-12)


def test_cli_refuses_a_clip_box_on_a_volume(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    np.save("vol.npy", np.random.default_rng(0).random((6, 6, 6)))
    status = cli.main(
        ["mesh", "vol.npy", "--clip-box", "0", "0", "0", "1", "1", "1", "-o", "v.ply"]
    )
    err = capsys.readouterr().err
    assert status == 2
    assert err.strip().splitlines() == [
        "rdmesh: error: --clip-box does not apply to a volume: use --border clipped to clip it "
        "to its box"
    ]


def test_the_box_grid_reaches_every_box_edge_of_any_box():
    """Bounds such as 0.7 = -0.4 + 1.1 * 1 + rounding: the grid's last lattice
    line is the bound itself, so the grid edges on the box's 12 edges are all
    found (before, those on the high faces were missed and a plane lost 3 of
    its 4 corners)."""
    from rdmesh.sampling.boundary import box_grid

    x, ends, _, on_edge = box_grid(PLANE_BOX, 0.025)
    assert np.all(on_faces(x, PLANE_BOX).any(axis=1))
    assert np.all((x >= PLANE_BOX[0]) & (x <= PLANE_BOX[1]))
    length = np.linalg.norm(x[ends[on_edge, 0]] - x[ends[on_edge, 1]], axis=1).sum()
    assert length == pytest.approx(4 * (PLANE_BOX[1] - PLANE_BOX[0]).sum(), rel=1e-12)
