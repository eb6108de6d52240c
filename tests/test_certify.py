"""Certify mode (issue 13): proven component discovery, proven root isolation,
and the Voronoi edges' crossings proven by interval arithmetic."""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
from hypothesis import given, settings
from hypothesis import strategies as st
from rdmesh.sampling.discovery import discover
from rdmesh.sampling.isolate import isolate_roots
from rdmesh.surfaces.expressions import parse_expression

#: A unit sphere and a sphere of radius 0.02 (the grid's cell is 0.0625) (issue 13).
SMALL = "min(sqrt(x**2+y**2+z**2)-1, sqrt((x-1.5)**2+(y-0.3)**2+(z-0.2)**2)-0.02)"


def _surface(text, radius=2.0):
    return rdmesh.ImplicitSurface.from_expression(text, bounding_sphere=((0, 0, 0), radius))


@pytest.mark.parametrize(
    ("method", "radius_bound"), [("topological-ball", None), ("boissonnat-oudot", 0.2)]
)
def test_issue_example_is_certified_with_both_components(method, radius_bound):
    m = rdmesh.mesh_surface(
        _surface(SMALL), method=method, radius_bound=radius_bound, certify=True
    )
    topo = m.topology()
    assert topo["components"] == 2 and topo["euler"] == [2, 2]
    assert m.is_closed_manifold()
    centre = np.array([1.5, 0.3, 0.2])
    near = np.linalg.norm(m.vertices - centre, axis=1) < 0.05
    assert near.sum() >= 4
    assert np.allclose(np.linalg.norm(m.vertices[near] - centre, axis=1), 0.02, atol=1e-9)
    rep = m.report
    assert rep["seeding"]["level"] == "proven"
    assert rep["tests"]["voronoi_edge"]["level"] == "proven"
    assert rep["tests"]["voronoi_edge"]["proof"]["held"]
    assert rep["tests"]["voronoi_loop"]["level"] == "proven"
    assert rep["tests"]["silhouette"]["level"] == "proven"
    assert m.topology_certified and rep["certified"]


# Components that the seeding grid (64 cells across the ball) cannot see:
# (expression, bounding radius, centres and radii of the spheres).
HARD = {
    "radius-0.5%": (
        "min(x**2+y**2+z**2-1, (x-1.3)**2+(y-0.1)**2+z**2-0.01**2)",
        2.0,
        [((0, 0, 0), 1.0), ((1.3, 0.1, 0), 0.01)],
    ),
    "three-specks": (
        "min(min(x**2+y**2+z**2-0.25, (x-1)**2+y**2+z**2-0.004**2), "
        "(x+0.3)**2+(y-1.1)**2+(z-0.4)**2-0.003**2)",
        1.6,
        [((0, 0, 0), 0.5), ((1, 0, 0), 0.004), ((-0.3, 1.1, 0.4), 0.003)],
    ),
    "gap-0.2%": (
        "min(sqrt(x**2+y**2+z**2)-1, sqrt((x-2.004)**2+y**2+z**2)-1)",
        3.2,
        [((0, 0, 0), 1.0), ((2.004, 0, 0), 1.0)],
    ),
}


@pytest.mark.parametrize("case", sorted(HARD))
def test_discovery_puts_a_point_on_every_component(case):
    text, radius, spheres = HARD[case]
    s = _surface(text, radius)
    found = discover(s, s.f, np.random.default_rng(3))
    assert found.proven and len(found.unresolved) == 0
    # Every point is on the surface, and every sphere has one.
    assert np.all(np.abs(s(found.points)) < 1e-7)
    for centre, r in spheres:
        d = np.abs(np.linalg.norm(found.points - np.array(centre), axis=1) - r)
        assert d.min() < 1e-7 * radius, (centre, r)


def test_discovery_boxes_with_two_monotone_partials_meet_the_face_condition():
    # Such boxes are good without bounding their faces: check on random
    # boxes near a torus that the faces, bounded, would have agreed.
    text = "(x**2 + y**2 + z**2 + 1 - 0.16)**2 - 4*(x**2 + y**2)"
    s = _surface(text, 2.0)
    rng = np.random.default_rng(6)
    size = 0.05
    lo = rng.uniform(-1.5, 1.5, (20000, 3))
    enc = s.f.interval_gradient(lo, lo + size)
    mono = ((enc.glo > 0) | (enc.ghi < 0)) & ~enc.undefined[:, None]
    two = np.flatnonzero(mono.sum(axis=1) >= 2)
    assert len(two) > 500
    for k in range(3):
        rows = two[mono[two, k]]
        inplane = [i for i in range(3) if i != k]
        for side in (0.0, size):
            flo = lo[rows].copy()
            flo[:, k] += side
            fhi = lo[rows] + size
            fhi[:, k] = flo[:, k]
            e = s.f.interval_gradient(flo, fhi)
            flat = ((e.glo[:, inplane] > 0) | (e.ghi[:, inplane] < 0)).any(axis=1)
            assert np.all(flat | (e.lo > 0) | (e.hi < 0))


def test_discovery_leaves_singular_and_undefined_regions_unresolved():
    """Two spheres touching at (1, 0, 0), where grad f = 0: the boxes there
    never settle, so the discovery is not proven and names the region; the
    run still returns, uncertified, without an exception. A function
    undefined across the surface (sqrt of x < 0) is not proven either."""
    text = "(x**2+y**2+z**2-1)*((x-2)**2+y**2+z**2-1)"
    s = _surface(text, 3.5)
    found = discover(s, s.f, np.random.default_rng(0))
    assert not found.proven
    assert np.linalg.norm(found.unresolved - [1, 0, 0], axis=1).min() < 0.01
    m = rdmesh.mesh_surface(_surface(text, 3.5), radius_bound=0.3, certify=True)
    assert m.report["seeding"]["level"] == "sampled"
    assert m.report["seeding"]["unresolved_regions"]
    assert not m.topology_certified
    s = _surface("sqrt(x + 0.5) + y**2 + z**2 - 0.5", 2.0)
    found = discover(s, s.f, np.random.default_rng(0))
    assert not found.proven and len(found.unresolved)


def test_isolation_counts_close_pairs_and_flags_tangency():
    """Two roots 2e-4 apart are both isolated; a double root is left unresolved
    (never counted as 0 or 2)."""
    close = parse_expression("(x - 0.5)**2 - 1e-8 + 0*y + 0*z")
    double = parse_expression("(x - 0.5)**2 + 0*y + 0*z")
    a = np.array([[0.0, 0.0, 0.0]])
    b = np.array([[1.0, 0.0, 0.0]])
    iso = isolate_roots(close, a, b, 1e-12)
    assert iso.resolved[0] and iso.count[0] == 2
    assert np.all((iso.lo <= 0.5 - 1e-4 + 1e-12) | (iso.hi >= 0.5 + 1e-4 - 1e-12))
    assert np.all(iso.hi - iso.lo > 0)
    iso = isolate_roots(double, a, b, 1e-9)
    assert not iso.resolved[0] and len(iso.pending_segment)


def test_isolation_matches_dense_sampling_on_random_segments():
    expr = parse_expression("x**4 - 5*x**2 + y**4 - 5*y**2 + z**4 - 5*z**2 + 11.8")
    rng = np.random.default_rng(1)
    a = rng.uniform(-2.5, 2.5, (3000, 3))
    b = a + rng.normal(size=(3000, 3))
    iso = isolate_roots(expr, a, b, 1e-10)
    t = np.linspace(0, 1, 4001)
    v = expr((a[:, None, :] + t[None, :, None] * (b - a)[:, None, :]).reshape(-1, 3))
    dense = (np.diff(np.sign(v.reshape(len(a), -1)), axis=1) != 0).sum(axis=1)
    assert iso.resolved.all()
    # Dense sampling can only miss roots, never invent them.
    assert np.all(iso.count >= dense)
    assert (iso.count == dense).mean() > 0.99
    # Each bracket holds a sign change of f.
    p = lambda s: a[iso.segment] + s[:, None] * (b - a)[iso.segment]  # noqa: E731
    assert np.all(np.sign(expr(p(iso.lo))) != np.sign(expr(p(iso.hi))))


def test_certify_needs_an_expression():
    s = rdmesh.surfaces.sphere()
    with pytest.raises(ValueError, match="expression"):
        rdmesh.mesh_surface(s, certify=True)
    with pytest.raises(ValueError, match="certify"):
        rdmesh.mesh_surface(_surface("x**2+y**2+z**2-1"), certify="yes")


def test_sampled_mode_says_so():
    m = rdmesh.mesh_surface(_surface("x**2+y**2+z**2-1"), method="topological-ball", certify=False)
    # The component search runs without certify too (issue 30); the tests stay sampled.
    assert m.report["seeding"]["level"] == "proven"
    assert not m.report["certified"]
    assert m.report["tests"]["voronoi_edge"]["level"] == "sampled"
    assert "proof" not in m.report["tests"]["voronoi_edge"]


def _cells(text, points, radius=2.0):
    """A core holding ``points``, and what the proven cell tests need."""
    from rdmesh import core
    from rdmesh.topology.proven_cells import CellGeometry
    from scipy.spatial import cKDTree

    s = _surface(text, radius)
    rdt = core.RestrictedDelaunay(s.centre, s.radius)
    rdt.insert(np.asarray(points, float))
    v = rdt.samples()
    normals = s.grad(v) / np.linalg.norm(s.grad(v), axis=1)[:, None]
    return s, rdt, v, normals, CellGeometry.of(rdt, v, s.centre, s.radius), cKDTree(v)


def _octahedron(r=1.0):
    return r * np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1.0]])


def test_proven_silhouette_fails_on_hemispheres_and_holds_on_smaller_cells():
    from rdmesh.topology.proven_cells import prove_cells

    sphere = "x**2 + y**2 + z**2 - 1"
    # Two samples: each cell holds a closed hemisphere, whose rim is a silhouette.
    s, rdt, v, n, geo, tree = _cells(sphere, [[0, 0, 1], [0, 0, -1]])
    out = prove_cells(s, rdt, v, n, geo, tree, [0, 1]).violations
    assert out.count == 2
    # Every refinement point is on the sphere, near the rim.
    assert np.allclose(np.linalg.norm(out.centres, axis=1), 1, atol=1e-8)
    assert np.all(np.abs(out.centres[:, 2]) < 0.05)
    # Six samples (an octahedron): every cell's patch has normals within 55
    # degrees of its sample's; the proof holds.
    s, rdt, v, n, geo, tree = _cells(sphere, _octahedron())
    out = prove_cells(s, rdt, v, n, geo, tree, np.arange(6)).violations
    assert out.count == 0


def test_proven_loop_test_finds_a_loop_inside_a_facet():
    from rdmesh.topology.proven_cells import proven_loop_test

    # Samples off a small sphere, one above and one below: the bisector plane
    # z = 0 cuts the sphere in a closed circle inside the facet.
    small = "x**2 + y**2 + z**2 - 0.09"
    s, rdt, v, n, geo, tree = _cells(small, [[0, 0, 0.5], [0, 0, -0.5]])
    out = proven_loop_test(s, v, geo, tree)
    assert out.count >= 1
    assert np.allclose(np.linalg.norm(out.centres, axis=1), 0.3, atol=1e-8)
    # Samples on the sphere, an octahedron: each facet meets it in one arc.
    s, rdt, v, n, geo, tree = _cells(small, _octahedron(0.3))
    assert proven_loop_test(s, v, geo, tree).count == 0


@pytest.mark.parametrize(
    "text",
    ["(x**2 + y**2 + z**2 + 1 - 0.16)**2 - 4*(x**2 + y**2)", "x**4 + y**4 + z**4 - 1"],
)
def test_proven_edge_test_gives_the_same_counts_from_the_proven_cells(text):
    # Searching a Voronoi edge only inside a proven cell's leaves must find
    # exactly the crossings of the whole edge: both counts are proven.
    from rdmesh.sampling import isolate
    from rdmesh.topology import proven
    from rdmesh.topology.proven_cells import prove_cells

    rng = np.random.default_rng(2)
    x = rng.uniform(-1.5, 1.5, (60000, 3))
    s = _surface(text, 2.0)
    x = x[np.argsort(np.abs(s(x)))[:1500]]
    s, rdt, v, n, geo, tree = _cells(text, x)
    cells = prove_cells(s, rdt, v, n, geo, tree, np.arange(len(v)))
    assert cells.seeded.mean() > 0.5
    counts = []
    real = isolate.isolate_roots
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(proven, "isolate_roots", lambda *a: counts.append(real(*a)) or counts[-1])
        for seeded in (None, cells):
            proven.proven_edge_test(
                s, rdt, v, np.zeros((0, 3), np.int64), np.zeros((0, 3)), seeded
            )
    whole, part = counts
    both = whole.resolved & part.resolved
    assert both.mean() > 0.99 and whole.count.sum() > 1000
    assert np.array_equal(whole.count[both], part.count[both])
    assert part.boxes < whole.boxes  # and with less work


def test_chords_pair_the_two_restricted_facets_of_an_edge():
    from rdmesh.topology.proven_cells import _chords, _edge_keys

    edges = np.array([[0, 1], [0, 2], [1, 2], [1, 3], [2, 3], [3, 4]])
    tri = np.array([[2, 1, 0], [1, 3, 2], [3, 4, 9]])  # (1, 2) is in the first two only
    centres = np.array([[0.0, 0, 0], [1.0, 2, 3], [5.0, 5, 5]])
    for order in (np.arange(6), np.array([5, 3, 0, 4, 2, 1])):  # sorted, and not
        rows, chord = _chords(_edge_keys(edges[order]), tri, centres)
        assert np.array_equal(edges[order][rows], [[1, 2]])
        # Between the two facets' centres (either way: the sign does not matter).
        assert np.array_equal(np.abs(chord), [[1.0, 2, 3]])


def test_proof_memo_keeps_the_leaves_of_unchanged_cells():
    # A second proof after a few insertions reuses the clean cells that did
    # not change: their leaves must be exactly a fresh proof's.
    from rdmesh.topology.proven_cells import CellGeometry, ProofMemo, prove_cells
    from scipy.spatial import cKDTree

    text = "x**2/1.44 + y**2 + z**2/0.49 - 1"
    rng = np.random.default_rng(4)
    x = rng.uniform(-1.3, 1.3, (40000, 3))
    s = _surface(text, 2.0)
    x = x[np.argsort(np.abs(s(x)))[:400]]
    s, rdt, v, n, geo, tree = _cells(text, x)
    memo = ProofMemo()
    first = prove_cells(s, rdt, v, n, geo, tree, np.arange(len(v)), memo)
    assert first.seeded.sum() > 100
    # Three more samples near one end of the ellipsoid.
    rdt.insert(np.array([[1.2, 0.0, 0.0], [1.19, 0.05, 0.0], [1.19, 0.0, 0.05]]))
    v = rdt.samples()
    n = s.grad(v) / np.linalg.norm(s.grad(v), axis=1)[:, None]
    geo, tree = CellGeometry.of(rdt, v, s.centre, s.radius), cKDTree(v)
    ids = np.arange(len(v))
    again = prove_cells(s, rdt, v, n, geo, tree, ids, memo)
    fresh = prove_cells(s, rdt, v, n, geo, tree, ids)
    assert np.array_equal(again.seeded, fresh.seeded)
    _, touched = memo.touched(rdt, len(x), len(v))
    kept = np.setdiff1d(np.flatnonzero(first.seeded), touched)
    assert 100 < len(kept) < first.seeded.sum()
    for p in kept:
        a = slice(again.first[p], again.first[p + 1])
        b = slice(fresh.first[p], fresh.first[p + 1])
        assert np.array_equal(again.lo[a], fresh.lo[b])
        assert np.array_equal(again.hi[a], fresh.hi[b])


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    width=st.integers(1, 3),
    top=st.sampled_from([3, 60, 10**6, 2**40, 2**62]),
)
def test_row_index_finds_each_row_in_the_table(seed, width, top):
    # The proofs look up facets and edges with it; keys of any size.
    from rdmesh._vectors import row_index

    rng = np.random.default_rng(seed)
    table = rng.integers(0, top, (rng.integers(0, 40), width))
    rows = rng.integers(0, top, (rng.integers(0, 40), width))
    if len(table):
        rows = np.concatenate([rows, table[rng.integers(0, len(table), 10)]])
    got = row_index(rows, table)
    present = np.array([any((t == r).all() for t in table) for r in rows], bool)
    assert np.array_equal(got >= 0, present)
    assert np.array_equal(table[got[present]], rows[present])
    # A repeated row of the table gives its last position.
    for r, i in zip(rows[present], got[present], strict=True):
        assert not (table[i + 1 :] == r).all(axis=1).any()
