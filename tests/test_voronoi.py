"""Voronoi facets from the core and the T2 loop test (rdmesh.topology.loops)."""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
from hypothesis import given, settings
from hypothesis import strategies as st
from rdmesh.core import _rdt
from rdmesh.sampling.probes import Probes
from rdmesh.topology.complex import complex_status, is_closed_manifold
from rdmesh.topology.loops import LoopMemo, loop_test
from scipy.spatial import cKDTree


def _cloud(seed=0, n=200):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 3))
    x /= np.linalg.norm(x, axis=1)[:, None]
    x *= 1.0 + 0.05 * rng.random(n)[:, None]
    rdt = _rdt.RestrictedDelaunay(np.zeros(3), 2.0)
    rdt.insert(x)
    return rdt, rdt.samples()  # ids follow the core's insertion order


def test_voronoi_facets_are_bisector_polygons_of_empty_spheres():
    rdt, x = _cloud()
    edges = rdt.delaunay_edges()
    off, pts, cell, third = rdt.voronoi_facets(edges)
    sizes = np.diff(off)
    assert len(off) == len(edges) + 1 and sizes.min() >= 3
    owner = np.repeat(np.arange(len(edges)), sizes)
    p, q = x[edges[owner, 0]], x[edges[owner, 1]]
    dp = np.linalg.norm(pts - p, axis=1)
    # Equidistant from p and q: in the bisector plane.
    assert np.allclose(dp, np.linalg.norm(pts - q, axis=1), rtol=1e-9, atol=1e-9)
    # Vertex j is the circumcentre of the cell holding p, q, third[j-1], third[j].
    prev = (np.arange(len(pts)) - off[owner] - 1) % sizes[owner] + off[owner]
    for w in (third, third[prev]):
        real = w >= 0
        dw = np.linalg.norm(pts[real] - x[w[real]], axis=1)
        assert np.allclose(dw, dp[real], rtol=1e-9, atol=1e-9)
    # Empty spheres: no sample nearer than p (Delaunay).
    near, _ = cKDTree(x).query(pts)
    assert np.all(near >= dp * (1 - 1e-9) - 1e-12)
    # Each polygon edge is dual to the Delaunay facet (p, q, third).
    real = third >= 0
    tri = np.column_stack([edges[owner, 0], edges[owner, 1], third])[real]
    assert rdt.is_facet(tri).all()
    # Convex: consecutive turns all have the same sign about the edge axis.
    nxt = (np.arange(len(pts)) - off[owner] + 1) % sizes[owner] + off[owner]
    axis = q - p
    turn = np.einsum("ij,ij->i", np.cross(pts - pts[prev], pts[nxt] - pts), axis)
    scale = np.linalg.norm(pts - pts[prev], axis=1) * np.linalg.norm(pts[nxt] - pts, axis=1)
    sig = turn / np.maximum(scale * np.linalg.norm(axis, axis=1), 1e-300)
    for k in range(len(edges)):
        s = sig[off[k] : off[k + 1]]
        s = s[np.abs(s) > 1e-9]
        assert np.all(s > 0) or np.all(s < 0)
    # Distinct cells are numbered consistently.
    for c in np.unique(cell)[:50]:
        assert np.ptp(pts[cell == c], axis=0).max() < 1e-12


def test_delaunay_edges_of_stars():
    rdt, x = _cloud(1, 80)
    every = rdt.delaunay_edges()
    assert np.all(every[:, 0] < every[:, 1])
    assert len(np.unique(every, axis=0)) == len(every)
    star = rdt.delaunay_edges(np.array([3, 7]))
    keys = set(map(tuple, every))
    assert set(map(tuple, star)) <= keys
    offs, adj = rdt.neighbours(np.array([3]))
    assert {tuple(sorted((3, int(v)))) for v in adj} <= set(map(tuple, star))
    assert np.array_equal(rdt.delaunay_edges(np.arange(len(x))), every)


def test_every_edge_and_its_facet_box_and_every_cell_box_in_one_pass():
    rdt, x = _cloud(2, 150)
    edges, box, cell_box = rdt.voronoi_boxes()
    # The same edges as the sample's neighbour lists, sorted and each once.
    offs, adj = rdt.neighbours(np.arange(len(x)))
    src = np.repeat(np.arange(len(x)), np.diff(offs))
    keep = src < adj
    pairs = np.column_stack([src[keep], adj[keep]])
    assert np.array_equal(edges, pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))])
    assert np.array_equal(rdt.delaunay_edges(), edges)
    # Each box is the extent of the facet's polygon, circulated around the edge.
    off, pts, _, _ = rdt.voronoi_facets(edges)
    assert np.array_equal(box[:, 0], np.minimum.reduceat(pts, off[:-1], axis=0))
    assert np.array_equal(box[:, 1], np.maximum.reduceat(pts, off[:-1], axis=0))
    # And each sample's cell box, as the core finds it from the sample's star.
    assert np.array_equal(cell_box, rdt.voronoi_cell_boxes(np.arange(len(x))))


@pytest.mark.parametrize(
    ("edges", "match"),
    [
        (np.array([[0, 500]]), "out of range"),
        (np.array([[-1, 2]]), "out of range"),
        (np.array([[4, 4]]), "itself"),
        (np.zeros((2, 3), np.int64), r"shape \(m, 2\)"),
    ],
)
def test_voronoi_facets_bad_ids(edges, match):
    rdt, _ = _cloud(2, 60)
    with pytest.raises(ValueError, match=match):
        rdt.voronoi_facets(edges)


def test_voronoi_facets_non_edge_raises():
    rdt, x = _cloud(3, 60)
    every = set(map(tuple, rdt.delaunay_edges()))
    pair = next((i, j) for i in range(60) for j in range(i + 1, 60) if (i, j) not in every)
    with pytest.raises(ValueError, match="not a Delaunay edge"):
        rdt.voronoi_facets(np.array([pair]))
    with pytest.raises(ValueError, match="out of range"):
        rdt.delaunay_edges(np.array([99]))


# -- the loop test on hand-made configurations --------------------------------

P, Q = np.array([-0.5, 0.0, 0.0]), np.array([0.5, 0.0, 0.0])
RING = np.array([[0, 2.0, 0], [0, -2.0, 0], [0, 0, 2.0], [0, 0, -2.0], [2.5, 0, 0], [-2.5, 0, 0]])


def _setup():
    rdt = _rdt.RestrictedDelaunay(np.zeros(3), 3.0)
    v = np.concatenate([[P, Q], RING])
    for k in range(len(v)):  # one at a time: ids in this order
        assert rdt.insert(v[k : k + 1])[0] == k
    return rdt, v


def _sphere(c, r):
    c = np.asarray(c, float)

    def f(x):
        return np.einsum("ij,ij->i", x - c, x - c) - r * r

    def g(x):
        return 2 * (x - c)

    return rdmesh.ImplicitSurface(f, ((0, 0, 0), 3.0), gradient=g)


def _probes_on(c, r, n=400):
    rng = np.random.default_rng(0)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    pts = np.asarray(c) + r * d
    return Probes(pts, d, 0.05)


def test_loop_inside_a_facet_is_found():
    """A small sphere centred in the bisector plane of p, q meets F_pq in a
    circle that does not reach the facet's boundary: a loop (k = 0)."""
    rdt, v = _setup()
    s = _sphere((0, 0.1, -0.05), 0.2)
    empty = np.zeros((0, 3), np.int64)
    status = complex_status(empty, len(v))
    memo = LoopMemo()
    out = loop_test(
        s, rdt, v, empty, np.zeros((0, 3)), status, _probes_on((0, 0.1, -0.05), 0.2), None, memo
    )
    assert [tuple(e) for e in out.edges] == [(0, 1)]
    x = out.centres[0]
    assert abs(x[0]) < 1e-9 and abs(s(x[None])[0]) < 1e-6
    assert np.isclose(out.radii[0], np.linalg.norm(x - P))
    # The refinement point is the centre of an empty ball.
    assert np.linalg.norm(v - x, axis=1).min() >= out.radii[0] * (1 - 1e-9)
    # Without a probe near it the facet is not tested (documented limit).
    far = loop_test(s, rdt, v, empty, np.zeros((0, 3)), status, _probes_on((0, 0, 2.6), 0.1))
    assert len(far.edges) == 0


def test_sphere_away_from_the_facets_gives_nothing():
    rdt, v = _setup()
    # A sphere around p only: it stays inside p's Voronoi cell.
    s = _sphere(P, 0.2)
    empty = np.zeros((0, 3), np.int64)
    status = complex_status(empty, len(v))
    out = loop_test(s, rdt, v, empty, np.zeros((0, 3)), status, _probes_on(P, 0.2))
    assert len(out.edges) == 0


def _polygon(rdt, e):
    off, pts, _, third = rdt.voronoi_facets(np.array([e]))
    return pts, third


def _wave(x):
    return x[:, 2] - 0.4 * np.sin(10 * x[:, 1]) - 0.5 * x[:, 1]


def test_folded_arc_is_found():
    """In the plane x = 0, z = 0.4 sin(10 y) + 0.5 y crosses the square facet
    F_pq once on each side edge (k = 2) and runs backwards along its chord in
    between: a folded arc. No gradient is given (finite differences)."""
    rdt, v = _setup()
    pts, third = _polygon(rdt, (0, 1))
    s = rdmesh.ImplicitSurface(_wave, ((0, 0, 0), 3.0))
    # The crossings: on the facet edges at y = -h and y = +h (h = 0.9375).
    h = np.abs(pts[:, 1]).max()
    assert np.allclose(np.abs(pts[:, 1:]), h)
    ends = np.array([[0.0, -h, 0.0], [0.0, h, 0.0]])
    ends[:, 2] = -_wave(ends)
    assert np.all(np.abs(ends[:, 2]) < h)
    # Third vertices of the two side edges (edge j runs from pts[j] to pts[j+1]).
    nxt = np.roll(pts, -1, axis=0)
    side = [int(np.flatnonzero((pts[:, 1] == y) & (nxt[:, 1] == y))[0]) for y in (-h, h)]
    tri = np.array([[0, 1, third[j]] for j in side], np.int64)
    assert tri[:, 2].min() >= 0
    status = complex_status(tri, len(v))
    out = loop_test(s, rdt, v, tri, ends, status)
    assert [tuple(e) for e in out.edges] == [(0, 1)]
    x = out.centres[0]
    assert abs(x[0]) < 1e-9 and abs(_wave(x[None])[0]) < 1e-6
    assert np.linalg.norm(v - x, axis=1).min() >= out.radii[0] * (1 - 1e-9)
    # The same facet crossed by a straight line along the chord: nothing.
    flat = rdmesh.ImplicitSurface(lambda x: x[:, 2] - 0.5 * x[:, 1], ((0, 0, 0), 3.0))
    ends[:, 2] = 0.5 * ends[:, 1]
    assert len(loop_test(flat, rdt, v, tri, ends, status).edges) == 0


def test_memo_skips_unchanged_facets():
    rdt, v = _setup()
    s = _sphere(P, 0.2)
    empty = np.zeros((0, 3), np.int64)
    status = complex_status(empty, len(v))
    pr = _probes_on((0, 0.5, 0.5), 0.1)
    memo = LoopMemo()
    loop_test(s, rdt, v, empty, np.zeros((0, 3)), status, pr, None, memo)
    first = memo.tested
    loop_test(s, rdt, v, empty, np.zeros((0, 3)), status, pr, None, memo)
    assert first > 0 and memo.tested == first


# -- in the report ---------------------------------------------------------------


def test_report_has_the_loop_test(sphere_case):
    rep = sphere_case.mesh.report
    t = rep["tests"]["voronoi_loop"]
    assert t["held"] is True and t["violations"] == 0 and t["basis"] == "sampled"
    assert "damped Newton" in t["tests"] and "missed by every seed is not seen" in t["tests"]
    assert list(rep["tests"]).index("voronoi_loop") == 2
    assert "voronoi_loop" in sphere_case.mesh.stats["phase_seconds"]


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 60), st.integers(3, 12))
def test_complex_status_counts_every_edge(seed, n_faces, n_vertices):
    """Edge keys, counts and each facet's edges against np.unique, on random
    triangle sets (repeated faces and edges of any multiplicity)."""
    rng = np.random.default_rng(seed)
    faces = np.array([rng.choice(n_vertices, 3, replace=False) for _ in range(n_faces)])
    faces = faces.reshape(-1, 3).astype(np.int64)
    status = complex_status(faces, n_vertices)
    pairs = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    keys = pairs[:, 0] * n_vertices + pairs[:, 1]
    want, count = np.unique(keys, return_counts=True)
    np.testing.assert_array_equal(status.edge_key, want)
    np.testing.assert_array_equal(status.edge_count, count)
    np.testing.assert_array_equal(status.edge_key[status.facet_edges].ravel(), keys)
    used = np.unique(faces)
    assert (status.vertex_fans[used] >= 1).all()


def _fans_reference(faces: np.ndarray, n: int) -> np.ndarray:
    """Fans around each vertex: components of its link, where each face
    (v, x, y) joins its other two vertices x and y."""

    def root(parent, x):
        while parent[x] != x:
            x = parent[x]
        return x

    fans = np.zeros(n, np.int64)
    for v in range(n):
        parent: dict[int, int] = {}
        for f in faces[(faces == v).any(axis=1)]:
            x, y = (int(u) for u in f if u != v)
            parent.setdefault(x, x)
            parent.setdefault(y, y)
            parent[root(parent, x)] = root(parent, y)
        fans[v] = sum(1 for x in parent if parent[x] == x)
    return fans


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 40), st.integers(3, 9))
def test_complex_status_counts_every_fan(seed, n_faces, n_vertices):
    """Fans around each vertex against a union-find of its link, on random
    triangle sets (bowties, fins and repeated faces included)."""
    rng = np.random.default_rng(seed)
    faces = np.array([rng.choice(n_vertices, 3, replace=False) for _ in range(n_faces)])
    faces = faces.reshape(-1, 3).astype(np.int64)
    status = complex_status(faces, n_vertices)
    np.testing.assert_array_equal(status.vertex_fans, _fans_reference(faces, n_vertices))


@pytest.mark.parametrize(
    ("faces", "match"),
    [([[0, 1, 5]], r"vertex id 5 outside \[0, 5\)"), ([[0, 1, -1]], r"vertex id -1"),
     ([[0, 2, 2]], r"repeats a vertex")],
)  # fmt: skip
def test_complex_status_rejects_bad_faces(faces, match):
    with pytest.raises(ValueError, match=match):
        complex_status(np.array(faces), 5)
    assert not is_closed_manifold(np.array([[0, 1, 2], [0, 2, 2]]), 5)
