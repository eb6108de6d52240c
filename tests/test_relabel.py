"""Pinched vertices below the spacing floor made one disk by relabelling cells.

Two unit spheres whose centres are 1.998 apart, meshed as one union with
features off, meet in a concave rim where the gap between the sheets is
thinner than the floor: the parity rule leaves the complex the boundary of a
cell labelling there, pinched at edges and vertices. The final relabelling
moves a group of cells at each pinched vertex across the surface, so the
mesh is closed, and says so in its report.
"""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest
import rdmesh
from hypothesis import given, settings
from hypothesis import strategies as st
from rdmesh import core
from rdmesh.refine import mesher
from rdmesh.topology.complex import complex_status, is_closed_manifold


def _touching(p: np.ndarray) -> np.ndarray:
    a = np.linalg.norm(p - [0.0, 0.0, 0.999], axis=1) - 1.0
    b = np.linalg.norm(p - [0.0, 0.0, -0.999], axis=1) - 1.0
    return np.minimum(a, b)


def _mesh():
    surface = rdmesh.ImplicitSurface(_touching, ((0.0, 0.0, 0.0), 2.2), features="none")
    return rdmesh.mesh_surface(surface, radius_bound=0.1, seed=0)


@pytest.fixture(scope="module")
def relabelled():
    return _mesh()


@pytest.fixture(scope="module")
def restricted():
    patch = pytest.MonkeyPatch()
    patch.setattr(mesher, "_relabel", lambda *args: None)
    try:
        return _mesh()
    finally:
        patch.undo()


def test_without_relabelling_the_complex_is_pinched(restricted):
    st = complex_status(restricted.faces, len(restricted.vertices))
    assert np.any(st.edge_count >= 4) or np.any(st.vertex_fans > 1)
    assert not restricted.report["closed_manifold"]
    assert restricted.report["relabelled"] is None


def test_relabelled_mesh_is_closed_and_says_so(relabelled):
    assert is_closed_manifold(relabelled.faces, len(relabelled.vertices))
    rep = relabelled.report
    assert rep["closed_manifold"] is True
    rel = rep["relabelled"]
    assert rel["pinched_vertices"] > 0 and rel["cells_flipped"] > 0
    assert rel["still_pinched"] == 0
    assert rel["regions"]
    # The rim: every changed face lies near the plane z = 0.
    assert all(abs(r["centre"][2]) < 0.01 for r in rel["regions"])
    assert rep["tbp_holds"] is False and rep["certified"] is False
    assert "pinched vertices" in rep["statement"]


def test_the_time_allowed_ends_the_relabelling_and_the_report_says_so(monkeypatch, relabelled):
    # As if the run's time_limit had passed before the relabelling started.
    from rdmesh.topology.relabel import relabel_pinches

    monkeypatch.setattr(mesher, "relabel_pinches", lambda *a: relabel_pinches(*a[:6], 0.0))
    late = _mesh()
    rel = late.report["relabelled"]
    assert relabelled.report["relabelled"]["timed_out"] is False
    assert rel["timed_out"] is True and rel["cells_flipped"] == 0
    assert rel["still_pinched"] == rel["pinched_vertices"] > 0
    assert late.report["closed_manifold"] is False
    assert "the time limit ended the relabelling" in late.report["statement"]


def test_changed_faces_are_counted(monkeypatch):
    # The same run but for the relabelling (both keeping their specks): the
    # faces that differ are those reported.
    monkeypatch.setattr(mesher, "_pockets", lambda *args: None)
    relabelled = _mesh()
    monkeypatch.setattr(mesher, "_relabel", lambda *args: None)
    restricted = _mesh()
    a = {tuple(sorted(map(tuple, relabelled.vertices[f].tolist()))) for f in relabelled.faces}
    b = {tuple(sorted(map(tuple, restricted.vertices[f].tolist()))) for f in restricted.faces}
    assert len(a ^ b) == relabelled.report["relabelled"]["faces_changed"]


def test_specks_in_the_gap_are_dropped_and_reported(relabelled):
    """The cells of the gap thinner than the floor that the relabelling seals
    off are tiny closed components next to the refused points: dropped, the
    report says how many and where; what is left is the union, one surface."""
    assert relabelled.report["components"] == 1
    p = relabelled.report["pockets"]
    assert p["specks"] is True and p["ruled_out"] is False and p["dropped"] > 0
    assert p["largest"] < 0.1  # below the size bound
    assert all(abs(r["centre"][2]) < 0.01 for r in p["regions"])  # at the rim
    assert "refused below the spacing floor" in relabelled.report["statement"]


def test_faces_stay_outward(relabelled):
    # A closed, consistently oriented surface around the union has the
    # union's volume (about 2 x 4.19 minus the lens of overlap).
    v = relabelled.vertices[relabelled.faces]
    volume = np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2])).sum() / 6
    assert 8.0 < volume < 8.4


def test_the_log_names_the_relabelling(caplog):
    with caplog.at_level("WARNING", logger="rdmesh"):
        _mesh()
    assert any("were relabelled" in r.getMessage() for r in caplog.records)


def test_a_smooth_surface_is_not_relabelled():
    m = rdmesh.mesh_surface(rdmesh.surfaces.torus(), radius_bound=0.1, seed=0)
    assert m.report["relabelled"] is None and m.report["closed_manifold"]


def _cells_sharing_an_edge():
    """A small triangulation and two of its cells that share an edge but no facet."""
    rng = np.random.default_rng(3)
    rdt = core.RestrictedDelaunay([0.0, 0.0, 0.0], 2.0)
    rdt.insert(rng.uniform(-0.5, 0.5, (60, 3)))
    pts = rdt.samples()  # by sample id (insertion sorts the points)
    cells, _ = rdt.star_cells(np.arange(60))
    cells = cells[(cells >= 0).all(axis=1)]
    for i in range(len(cells)):
        shared = np.array([len(np.intersect1d(cells[i], c)) for c in cells])
        j = np.flatnonzero(shared == 2)
        if len(j):
            return rdt, pts, cells, cells[[i, j[0]]]
    raise AssertionError("no two cells share only an edge")


def _outward(pts, cell):
    faces = []
    for d in range(4):
        t = [v for k, v in enumerate(cell) if k != d]
        p = pts[t]
        if np.linalg.det(np.stack([p[1] - p[0], p[2] - p[0], pts[cell[d]] - p[0]])) > 0:
            t = [t[0], t[2], t[1]]
        faces.append(t)
    return faces


def test_relabel_stars_makes_two_cells_on_an_edge_one_disk():
    rdt, pts, cells, pair = _cells_sharing_an_edge()
    faces = np.array(_outward(pts, pair[0]) + _outward(pts, pair[1]), np.int64)
    st = complex_status(faces, len(pts))
    assert np.any(st.edge_count == 4)
    edge = np.intersect1d(pair[0], pair[1])
    out, flipped, _ = rdt.relabel_stars(faces, edge, cells, np.ones(len(cells)))
    assert len(flipped) > 0
    assert is_closed_manifold(out, len(pts))
    # Still the boundary of a cell labelling: outward, enclosing a positive volume.
    v = pts[out]
    assert np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2])).sum() > 0


def test_cells_without_a_cost_are_never_moved():
    rdt, pts, cells, pair = _cells_sharing_an_edge()
    faces = np.array(_outward(pts, pair[0]) + _outward(pts, pair[1]), np.int64)
    edge = np.intersect1d(pair[0], pair[1])
    out, flipped, _ = rdt.relabel_stars(faces, edge, cells[:0], np.ones(0))
    assert len(flipped) == 0
    assert sorted(map(tuple, out.tolist())) == sorted(map(tuple, faces.tolist()))


@pytest.mark.parametrize(
    "faces, ids, message",
    [
        ([[0, 1, 99]], [0], "out of range"),
        ([[0, 1, 1]], [0], "repeats a vertex"),
        ([[0, 1, 2], [2, 1, 0]], [0], "twice"),
        ([[0, 1, 2]], [-1], "out of range"),
    ],
)
def test_relabel_stars_rejects_bad_input(faces, ids, message):
    rdt = core.RestrictedDelaunay([0.0, 0.0, 0.0], 2.0)
    rdt.insert(np.random.default_rng(0).uniform(-0.5, 0.5, (10, 3)))
    with pytest.raises(ValueError, match=message):
        rdt.relabel_stars(np.array(faces), np.array(ids), np.zeros((0, 4), np.int64), np.zeros(0))
    with pytest.raises(ValueError, match="cost"):
        rdt.relabel_stars(
            np.zeros((0, 3), np.int64), np.array([0]), np.zeros((2, 4), np.int64), np.zeros(1)
        )
    with pytest.raises(ValueError, match="out of range"):
        rdt.star_cells(np.array([10]))
    with pytest.raises(ValueError, match="max_seconds"):
        rdt.relabel_stars(
            np.zeros((0, 3), np.int64),
            np.array([0]),
            np.zeros((0, 4), np.int64),
            np.zeros(0),
            -1.0,
        )


def _boundary_of_labelling(pts, cells, inside):
    """Outward faces between cells labelled inside and the rest."""
    faces = []
    keys = {}
    for c, q in enumerate(cells):
        for d in range(4):
            t = tuple(sorted(v for k, v in enumerate(q) if k != d))
            keys.setdefault(t, []).append((c, q[d]))
    for t, owners in keys.items():
        if min(t) < 0:
            continue
        labels = [inside[c] for c, _ in owners]
        if len(owners) == 1 and labels[0]:
            raise AssertionError("an inside cell on the hull of the gathered cells")
        if len(owners) == 2 and labels[0] != labels[1]:
            c, d = owners[0] if labels[0] else owners[1]
            p = pts[list(t)]
            if np.linalg.det(np.stack([p[1] - p[0], p[2] - p[0], pts[d] - p[0]])) > 0:
                t = (t[0], t[2], t[1])
            faces.append(t)
    return np.array(faces, np.int64).reshape(-1, 3)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_relabelling_keeps_the_boundary_of_a_labelling(seed):
    """Random inside cells: after each pass of relabel_stars at the pinched
    vertices the faces still bound a labelling, consistently oriented (each
    edge is used as often in one direction as in the other); after the
    passes, nothing is pinched."""
    rng = np.random.default_rng(seed)
    rdt = core.RestrictedDelaunay([0.0, 0.0, 0.0], 2.0)
    rdt.insert(rng.uniform(-0.5, 0.5, (40, 3)))
    pts = rdt.samples()  # by sample id (insertion sorts the points)
    cells, _ = rdt.star_cells(np.arange(40))
    # Cells of the inner points only, so no inside cell touches a dummy.
    inner = np.flatnonzero(np.abs(pts).max(axis=1) < 0.3)
    eligible = (cells >= 0).all(axis=1) & np.isin(cells, inner).all(axis=1)
    inside = eligible & (rng.random(len(cells)) < 0.5)
    faces = _boundary_of_labelling(pts, cells, inside)
    if not len(faces):
        return
    from rdmesh.topology.relabel import MAX_PASSES, pinched_vertices

    n = len(pts)
    cost = rng.random(len(cells))
    out = faces
    for _ in range(MAX_PASSES):
        todo = pinched_vertices(complex_status(out, n), n)
        if not len(todo):
            break
        out, flipped, _ = rdt.relabel_stars(out, todo, cells, cost)
        assert len(flipped)
        directed = np.concatenate([out[:, [0, 1]], out[:, [1, 2]], out[:, [2, 0]]])
        uses = Counter(map(tuple, directed.tolist()))
        assert all(uses[(b, a)] == k for (a, b), k in uses.items())
    # The passes relabel_pinches makes leave no vertex pinched (no cell near
    # the dummies is inside, so every group may move).
    if len(out):
        assert not len(pinched_vertices(complex_status(out, n), n))


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_faces_that_bound_no_labelling_end_without_a_hang(seed):
    """Faces dropped at random from a labelling's boundary bound no labelling
    (edges in an odd number of faces): relabel_stars still ends, at every
    vertex of a face, and returns Delaunay facets only."""
    rng = np.random.default_rng(seed)
    rdt = core.RestrictedDelaunay([0.0, 0.0, 0.0], 2.0)
    rdt.insert(rng.uniform(-0.5, 0.5, (40, 3)))
    pts = rdt.samples()
    cells, _ = rdt.star_cells(np.arange(40))
    inner = np.flatnonzero(np.abs(pts).max(axis=1) < 0.3)
    eligible = (cells >= 0).all(axis=1) & np.isin(cells, inner).all(axis=1)
    faces = _boundary_of_labelling(pts, cells, eligible & (rng.random(len(cells)) < 0.5))
    faces = faces[rng.random(len(faces)) < 0.8]
    if not len(faces):
        return
    # Every vertex of a face, pinched or not.
    out, _, _ = rdt.relabel_stars(faces, np.unique(faces), cells, rng.random(len(cells)))
    assert rdt.is_facet(out).all()
