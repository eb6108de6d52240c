"""Volumes clipped to their box: VolumeSurface(border="clipped").

Each volume samples an expression over a box smaller than the shape, so the
isosurface leaves the box; the mesh is the part inside, with a boundary on
the box faces.
"""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
import volumes
from clipped_volumes import HI, LO, TORUS_BOX, corner_sphere, cylinder, plane, torus
from clipped_volumes import volume as _volume
from meshcheck import boundary_edges, edge_counts
from rdmesh import core
from rdmesh.sampling.boundary import box_grid
from scipy.optimize import brentq
from test_cli import load, run

SIZE, DISTANCE = 0.1, 0.01


def _faces_of(x: np.ndarray, box: np.ndarray) -> np.ndarray:
    """(N, 6) which box faces (lo x y z, hi x y z) each point lies on, to rounding."""
    tol = 1e-12 * float(np.max(box[1] - box[0]))
    return np.concatenate([np.abs(x - box[0]), np.abs(box[1] - x)], axis=1) <= tol


def _check(
    s: rdmesh.VolumeSurface, m: rdmesh.SurfaceMesh, loops: int, chi: int, size: float = SIZE
) -> dict:
    """What every clipped volume mesh satisfies; returns measured figures."""
    assert m.complete, m.stats.get("stop_reason")
    assert m.stats["topology"] == "manifold-with-boundary"
    assert m.is_manifold_with_boundary() and not m.is_closed_manifold()
    topo = m.topology()
    assert topo["components"] == 1
    assert topo["boundary_loops"] == [loops]
    assert topo["euler"] == [chi]
    box = s.box
    # Every vertex in the box (to rounding) and on the surface.
    v = m.vertices
    assert np.all(v >= box[0] - 1e-12) and np.all(v <= box[1] + 1e-12)
    assert np.abs(s(v)).max() <= 1e-6
    edges, bv = boundary_edges(m.faces)
    on = _faces_of(v, box)
    # Boundary vertices: on a box face (to rounding) and on the surface (to
    # the projection's tolerance).
    assert on[bv].any(axis=1).all()
    grad = np.linalg.norm(s.grad(v[bv]), axis=1)
    assert (np.abs(s(v[bv])) / grad).max() <= 1e-9
    # Each boundary edge runs in one face (corners are samples), at most the
    # size bound long, and its midpoint is within the distance bound of the
    # curve (|f| over the gradient within that face).
    common = on[edges[:, 0]] & on[edges[:, 1]]
    assert common.any(axis=1).all()
    a, b = v[edges[:, 0]], v[edges[:, 1]]
    assert np.linalg.norm(a - b, axis=1).max() <= size + 1e-9
    mid = 0.5 * (a + b)
    g = s.grad(mid)
    axis = np.argmax(common, axis=1) % 3
    g[np.arange(len(g)), axis] = 0.0
    gap = np.abs(s(mid)) / np.linalg.norm(g, axis=1)
    assert gap.max() <= DISTANCE
    # Interior triangles keep the angle bound; those with an edge on the
    # boundary (a protecting ball's centre) are relaxed: measured only.
    assert m.features is not None and m.features.held
    assert len(edges) == m.features.edges
    exempt = (m.weights > 0)[m.faces].any(axis=1)
    assert m.angles[~exempt].min() >= 30.0 - 1e-9
    assert m.angles[exempt].min() >= 20.0
    rep = m.report
    assert rep["certified"] is False and m.topology_certified is False
    bd = rep["boundary"]
    assert bd["domain"] == "box"
    assert bd["curve_loops"] == bd["mesh_loops"] == loops and bd["loops_match"] is True
    assert bd["euler_consistent"] is True
    assert bd["basis"].startswith("sampled") and "box faces" in bd["basis"]
    assert "clip box" in rep["statement"] and "nothing is certified" in rep["statement"]
    return {"exempt_min_angle": float(m.angles[exempt].min()), "boundary_gap": float(gap.max())}


def _mesh(s):
    return rdmesh.mesh_surface(s, radius_bound=SIZE, distance_bound=DISTANCE)


def test_a_plane_through_the_box_is_a_disk_with_its_edge_crossings():
    s = _volume(plane)
    m = _mesh(s)
    _check(s, m, loops=1, chi=1)
    # The plane crosses the 4 vertical box edges: a boundary vertex at each,
    # where f = 0 on that edge.
    _, bv = boundary_edges(m.faces)
    assert m.report["boundary"]["edge_crossings"] == 4
    for x, y in [(-1, -1), (-1, 1), (1, -1), (1, 1)]:
        z = brentq(lambda t, x=x, y=y: float(s(np.array([[x, y, t]]))[0]), -1.0, 1.0)
        d = np.linalg.norm(m.vertices[bv] - [x, y, z], axis=1).min()
        assert d <= 1e-9
    # The tilted plane meets the 4 side faces along straight segments: the
    # boundary is about their polygon (length of the 4 segments). The cubic
    # interpolant of the sampled plane (mirror boundary) strays from it by
    # about 1.4e-3 at the faces, so its curve there is slightly wavy.
    edges, _ = boundary_edges(m.faces)
    length = np.linalg.norm(m.vertices[edges[:, 0]] - m.vertices[edges[:, 1]], axis=1).sum()
    assert length == pytest.approx(2 * np.hypot(2, 0.2) + 2 * 2, rel=1e-4)


def test_a_cylinder_longer_than_the_box_is_an_annulus():
    s = _volume(cylinder)
    m = _mesh(s)
    _check(s, m, loops=2, chi=0)
    assert m.report["boundary"]["edge_crossings"] == 0
    # Its two boundary loops lie on the top and bottom faces.
    _, bv = boundary_edges(m.faces)
    assert np.allclose(np.abs(m.vertices[bv, 2]), 1.0, atol=1e-12)


def test_a_sphere_cut_by_a_box_corner_has_a_vertex_at_each_edge_crossing():
    s = _volume(corner_sphere)
    m = _mesh(s)
    _check(s, m, loops=1, chi=1)
    assert m.report["boundary"]["edge_crossings"] == 3
    _, bv = boundary_edges(m.faces)
    for axis in range(3):

        def on_edge(t, axis=axis):
            p = np.ones((1, 3))
            p[0, axis] = t
            return float(s(p)[0])

        t = brentq(on_edge, -1.0, 1.0)
        crossing = np.ones(3)
        crossing[axis] = t
        assert np.linalg.norm(m.vertices[bv] - crossing, axis=1).min() <= 1e-9


def test_a_torus_cut_by_one_box_face_keeps_its_handle():
    # x <= 0.7 cuts the tube once: a torus with one hole, chi = 2 - 2 - 1.
    s = _volume(torus, *TORUS_BOX, n=32)
    m = _mesh(s)
    _check(s, m, loops=1, chi=-1)
    _, bv = boundary_edges(m.faces)
    assert np.allclose(m.vertices[bv, 0], 0.7, atol=1e-12)
    assert m.report["boundary"]["genus"] == [1.0]


def test_a_sizing_field_sets_the_edge_lengths_on_a_clipped_volume():
    """A field growing fourfold across the box, on the tilted plane's volume:
    the edges follow it, boundary chords included."""
    s = _volume(plane)

    def field(p):
        return 0.04 + 0.12 * np.clip((p[:, 0] - LO[0]) / (HI[0] - LO[0]), 0.0, 1.0)

    m = rdmesh.mesh_surface(s, radius_bound=field)
    _check(s, m, loops=1, chi=1, size=0.16)
    v, F = m.vertices, m.faces
    e = edge_counts(F)[0]
    length = np.linalg.norm(v[e[:, 0]] - v[e[:, 1]], axis=1)
    mid = 0.5 * (v[e[:, 0]] + v[e[:, 1]])
    fine, coarse = mid[:, 0] < LO[0] + 0.3, mid[:, 0] > HI[0] - 0.3
    # An edge is a chord of a surface ball within the field at its centre.
    assert length[fine].max() <= 2 * field(np.array([[LO[0] + 0.5, 0, 0]]))[0]
    # (1.7, not 2: the protecting balls of the boundary, half the spacing at
    # the box-edge corners, take a share of the coarse end's edges.)
    assert np.median(length[coarse]) >= 1.7 * np.median(length[fine])
    edges, _ = boundary_edges(F)
    a, b = v[edges[:, 0]], v[edges[:, 1]]
    assert np.all(np.linalg.norm(a - b, axis=1) <= field(0.5 * (a + b)) * (1 + 1e-9))


# -- what is refused ----------------------------------------------------------------


@pytest.fixture(scope="module")
def clipped():
    return _volume(plane, n=8)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (
            {"topology": "manifold"},
            r"'manifold' .* clipped to a box.*manifold-with-boundary",
        ),
        ({"topology": "non-manifold"}, r"topology 'non-manifold' .* border='closed'"),
        ({"method": "topological-ball"}, r"method 'topological-ball' .*method='boissonnat-oudot'"),
        ({"certify": True}, r"certify=True"),
    ],
)
def test_incompatible_options_are_refused_with_the_fix(clipped, kwargs, match):
    with pytest.raises(ValueError, match=match):
        rdmesh.mesh_surface(clipped, **kwargs)


def test_the_default_topology_of_a_clipped_volume_has_a_boundary_and_closed_stays_closed():
    vol = _volume(plane, n=8)
    assert vol.clip_box is not None and np.array_equal(vol.clip_box, vol.box)
    closed = _volume(plane, n=8, border="closed")
    assert closed.clip_box is None
    m = rdmesh.mesh_surface(closed, radius_bound=0.3)
    assert m.is_closed_manifold() and m.report["boundary"] is None


def test_a_clip_box_must_lie_in_the_bounding_sphere():
    s = _volume(plane, n=8)
    s.clip_box = np.array([[-2.0, -1.0, -1.0], [1.0, 1.0, 1.0]])
    with pytest.raises(ValueError, match="must lie inside its bounding sphere"):
        rdmesh.mesh_surface(s)


def test_a_bad_border_is_refused():
    with pytest.raises(ValueError, match=r"unknown border 'open'"):
        rdmesh.VolumeSurface(np.random.default_rng(0).random((5, 5, 5)), border="open")


# -- the core's clip box ------------------------------------------------------------


def test_the_core_clips_every_dual_segment_to_the_box():
    rng = np.random.default_rng(1)
    lo, hi = np.array([-0.3, -0.5, -0.2]), np.array([0.4, 0.1, 0.6])
    rdt = core.RestrictedDelaunay(np.zeros(3), 1.0)
    assert not rdt.has_clip_box
    rdt.set_clip_box(lo, hi)
    assert rdt.has_clip_box
    rdt.insert(rng.uniform(-0.9, 0.9, (300, 3)))
    seg = rdt.all_facets()[1].reshape(-1, 3)
    assert len(seg) > 0
    assert np.all(seg >= lo - 1e-12) and np.all(seg <= hi + 1e-12)
    # The same samples without the box: the clipped segments are the parts
    # of these (clipped to the ball only) inside the box, slab by slab.
    free = core.RestrictedDelaunay(np.zeros(3), 1.0)
    free.insert(rdt.samples())
    tri, fseg = free.all_facets()[:2]
    a, d = fseg[:, 0], fseg[:, 1] - fseg[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lo - a) / d, (hi - a) / d
    t_lo = np.maximum(0.0, np.nanmax(np.minimum(t0, t1), axis=1))
    t_hi = np.minimum(1.0, np.nanmin(np.maximum(t0, t1), axis=1))
    meets = t_lo < t_hi - 1e-9
    expect = {tuple(t): a[k] + t_lo[k] * d[k] for k, t in enumerate(tri) if meets[k]}
    got_tri, got_seg = rdt.all_facets()[:2]
    got = {tuple(t): s[0] for t, s in zip(got_tri, got_seg, strict=True)}
    assert 0 < len(got) < len(tri)
    assert set(expect) <= set(got) and len(got) - len(expect) <= 2
    assert max(np.abs(got[k] - v).max() for k, v in expect.items()) <= 1e-9


@pytest.mark.parametrize(
    ("lo", "hi", "error", "match"),
    [
        ((0, 0, 0), (1, 0, 1), ValueError, r"lo < hi"),
        ((0, 0, 0), (1, np.nan, 1), ValueError, r"finite"),
        ((0, 0), (1, 1), ValueError, r"shape \(3,\)"),
    ],
)
def test_bad_clip_boxes_are_refused(lo, hi, error, match):
    rdt = core.RestrictedDelaunay(np.zeros(3), 1.0)
    with pytest.raises(error, match=match):
        rdt.set_clip_box(np.asarray(lo, float), np.asarray(hi, float))


def test_the_clip_box_comes_before_the_first_insertion():
    rdt = core.RestrictedDelaunay(np.zeros(3), 1.0)
    rdt.insert(np.random.default_rng(0).uniform(-0.5, 0.5, (10, 3)))
    with pytest.raises(RuntimeError, match="before the first insertion"):
        rdt.set_clip_box(np.full(3, -0.5), np.full(3, 0.5))


def test_box_grid_is_one_closed_surface_with_its_box_edges():
    box = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 0.5]])
    x, ends, tri_edges, on_edge = box_grid(box, 0.2)
    # Every edge in exactly two triangles; Euler characteristic 2 (a sphere).
    assert np.all(np.bincount(tri_edges.ravel(), minlength=len(ends)) == 2)
    assert len(x) - len(ends) + len(tri_edges) == 2
    assert np.all(_faces_of(x, box).any(axis=1))
    # The grid edges on box edges cover the 12 box edges' total length.
    length = np.linalg.norm(x[ends[on_edge, 0]] - x[ends[on_edge, 1]], axis=1).sum()
    assert length == pytest.approx(4 * (1.0 + 2.0 + 0.5))
    assert np.linalg.norm(x[ends[:, 0]] - x[ends[:, 1]], axis=1).max() <= 0.2 * np.sqrt(2) + 1e-12


# -- command line -------------------------------------------------------------------


def _save(tmp_path, f, n=20):
    spacing = (HI - LO) / (n - 1)
    vol = -f(volumes.grid((n, n, n), spacing, LO).reshape(-1, 3)).reshape(n, n, n)
    np.save(tmp_path / "vol.npy", vol.astype(np.float32))
    return spacing


def test_cli_meshes_a_clipped_volume(tmp_path):
    spacing = _save(tmp_path, cylinder)
    out = run(
        "mesh", "vol.npy", "--isovalue", "0", "--spacing", *map(str, spacing),
        "--origin", "-1", "-1", "-1", "--border", "clipped", "--radius", "0.15",
        "-o", "cyl.ply", "--quiet", cwd=tmp_path,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    mesh = load(tmp_path / "cyl.ply")
    assert not mesh.is_watertight
    assert mesh.euler_number == 0
    assert np.allclose(mesh.bounds[:, 2], [-1.0, 1.0], atol=1e-9)


def test_cli_clipped_volume_with_a_closed_topology_is_one_line(tmp_path):
    _save(tmp_path, cylinder, n=8)
    out = run(
        "mesh", "vol.npy", "--isovalue", "0", "--border", "clipped", "--topology", "manifold",
        "-o", "o.ply", cwd=tmp_path,
    )  # fmt: skip
    assert out.returncode == 2
    assert "manifold-with-boundary" in out.stderr and "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1
