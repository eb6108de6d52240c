"""The C++ core rdmesh._rdt: insertion, incremental restricted facets, batching."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from meshcheck import face_normals
from rdmesh._geometry import circumradii
from rdmesh._vectors import segment_directions
from rdmesh.core import BAD, KNOWN, OUTWARD, RESTRICTED, TOPO, _rdt
from rdmesh.refine.criteria import FacetCriteria
from rdmesh.refine.facets import DualSamples, evaluate_facets
from rdmesh.surfaces import SURFACES


def _rdt_new(centre=(0.0, 0.0, 0.0), radius=2.0):
    return _rdt.RestrictedDelaunay(np.asarray(centre, float), radius)


# -- insertion ------------------------------------------------------------------


def test_insert_returns_ids_and_samples():
    rng = np.random.default_rng(0)
    rdt = _rdt_new()
    p = rng.uniform(-1, 1, (50, 3))
    ids = rdt.insert(p)
    assert ids.dtype == np.int64
    assert sorted(ids.tolist()) == list(range(50))
    assert rdt.number_of_samples == 50
    # samples() is indexed by id.
    assert np.array_equal(rdt.samples()[ids], p)
    q = rng.uniform(-1, 1, (20, 3))
    ids2 = rdt.insert(q)
    assert sorted(ids2.tolist()) == list(range(50, 70))
    assert np.array_equal(rdt.samples()[ids2], q)


def test_duplicates_get_existing_ids():
    rng = np.random.default_rng(1)
    rdt = _rdt_new()
    p = rng.uniform(-1, 1, (30, 3))
    ids = rdt.insert(p)
    # Re-inserting old points, plus a point twice within one batch.
    new = rng.uniform(-1, 1, (1, 3))
    batch = np.concatenate([p[[3, 17]], new, new, p[[3]]])
    ids2 = rdt.insert(batch)
    assert ids2[0] == ids[3] and ids2[1] == ids[17] and ids2[4] == ids[3]
    assert ids2[2] == ids2[3] == 30
    assert rdt.number_of_samples == 31
    assert np.array_equal(rdt.samples()[30], new[0])
    # Inserting only existing points changes no facet.
    tri = rdt.changed_facets()[0]
    rdt.update_facets(np.zeros(len(tri), np.uint8), np.zeros((len(tri), 3)))
    assert np.array_equal(rdt.insert(p[::-1]), ids[::-1])
    assert len(rdt.changed_facets()[0]) == 0


def test_insert_empty_batch():
    rdt = _rdt_new()
    assert rdt.insert(np.zeros((0, 3))).shape == (0,)
    assert rdt.number_of_samples == 0


@pytest.mark.parametrize(
    ("point", "match"),
    [
        pytest.param([np.nan, 0.0, 0.0], r"non-finite", id="nan"),
        pytest.param([0.0, np.inf, 0.0], r"non-finite", id="inf"),
        pytest.param([4.1, 0.0, 0.0], r"outside twice the bounding radius", id="far"),
        pytest.param([0.0, 0.0, -1e9], r"outside twice the bounding radius", id="very_far"),
    ],
)
def test_insert_bad_points(point, match):
    rdt = _rdt_new()
    rdt.insert(np.array([[0.1, 0.2, 0.3]]))
    batch = np.array([[0.5, 0.0, 0.0], point])
    with pytest.raises(ValueError, match=match):
        rdt.insert(batch)
    # Rejected before anything is inserted.
    assert rdt.number_of_samples == 1


def test_insert_bad_shape():
    rdt = _rdt_new()
    with pytest.raises(ValueError, match=r"shape \(n, 3\)"):
        rdt.insert(np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"shape \(n, 3\)"):
        rdt.insert(np.zeros(3))


@pytest.mark.parametrize(
    ("centre", "radius"),
    [
        ((0, 0, 0), -1.0),
        ((0, 0, 0), 0.0),
        ((0, 0, 0), np.nan),
        ((np.inf, 0, 0), 1.0),
        ((0, 0), 1.0),
    ],
)
def test_constructor_rejects_bad_sphere(centre, radius):
    with pytest.raises(ValueError):
        _rdt.RestrictedDelaunay(np.asarray(centre, float), radius)


def test_update_facets_length_must_match():
    rng = np.random.default_rng(2)
    rdt = _rdt_new()
    rdt.insert(rng.uniform(-1, 1, (40, 3)))
    tri = rdt.changed_facets()[0]
    k = len(tri)
    assert k > 0
    with pytest.raises(ValueError, match=r"one entry per facet"):
        rdt.update_facets(np.zeros(k - 1, np.uint8), np.zeros((k - 1, 3)))
    with pytest.raises(ValueError, match=r"matching"):
        rdt.update_facets(np.zeros(k, np.uint8), np.zeros((k + 1, 3)))
    # An insertion in between invalidates the pending list.
    rdt.insert(rng.uniform(-1, 1, (1, 3)))
    with pytest.raises(ValueError, match=r"no insert may come in between"):
        rdt.update_facets(np.zeros(k, np.uint8), np.zeros((k, 3)))


@pytest.mark.parametrize("share", [0.3, 0.001])
def test_labelled_facets_match_the_labelled_part_of_all_facets(share):
    """facets(BAD), facets(TOPO) and facets(BAD | TOPO) are the labelled part
    of facets(0), with the same centres and flags, round after round. With
    few labels (share 0.001) the core reads them from its list of marked
    facets, some gone or relabelled by the insertions in between; with many
    (0.3) it scans every cell."""
    rng = np.random.default_rng(3)
    rdt = _rdt_new()
    rdt.insert(rng.uniform(-1, 1, (3000, 3)))
    for _ in range(6):
        k = len(rdt.changed_facets()[0])
        flags = RESTRICTED | rng.choice([0, OUTWARD], k)
        flags |= (rng.random(k) < share) * BAD | (rng.random(k) < share) * TOPO
        rdt.update_facets(flags.astype(np.uint8), rng.uniform(-1, 1, (k, 3)))
        rdt.check()  # every labelled facet is in the marked list
        got = {mask: rdt.facets(mask) for mask in (BAD, TOPO, BAD | TOPO)}
        tri0, c0, fl0 = rdt.facets(0)
        for mask, (tri, centres, fl) in got.items():
            want = np.flatnonzero(fl0 & mask)
            assert len(want) > 0
            key = {tuple(t): i for i, t in enumerate(tri0[want].tolist())}
            idx = want[[key[tuple(t)] for t in tri.tolist()]]  # KeyError: not labelled
            assert len(set(idx.tolist())) == len(want)  # each labelled facet once
            np.testing.assert_array_equal(centres, c0[idx])
            np.testing.assert_array_equal(fl, fl0[idx])
        rdt.insert(rng.uniform(-1, 1, (20, 3)))


def test_facets_around_touched_samples_cover_every_changed_facet():
    """facets_around(ids) is the part of facets(0) with a vertex among ids,
    each facet once; after an insertion, every restricted facet that appeared
    or vanished has a vertex among take_touched()."""
    rng = np.random.default_rng(5)
    rdt = _rdt_new()
    rdt.insert(rng.uniform(-1, 1, (2000, 3)))

    def label():
        k = len(rdt.changed_facets()[0])
        flags = RESTRICTED | rng.choice([0, OUTWARD], k)
        rdt.update_facets(flags.astype(np.uint8), rng.uniform(-1, 1, (k, 3)))

    label()
    assert len(rdt.take_touched()) == 2000  # every sample is new
    assert len(rdt.take_touched()) == 0  # cleared
    for _ in range(4):
        before = _as_set(rdt.facets(0)[0])
        rdt.insert(rng.uniform(-1, 1, (15, 3)))
        label()
        touched = rdt.take_touched()
        assert np.all(np.diff(touched) > 0)
        assert 15 <= len(touched) < len(rdt.samples())
        tri0, c0, fl0 = rdt.facets(0)
        changed = np.array(sorted(before ^ _as_set(tri0)))
        assert len(changed) > 0
        assert np.all(np.isin(changed, touched).any(axis=1))
        tri, centres, fl = rdt.facets_around(touched)
        want = np.flatnonzero(np.isin(tri0, touched).any(axis=1))
        key = {tuple(t): i for i, t in enumerate(tri0.tolist())}
        idx = np.array([key[tuple(t)] for t in tri.tolist()])  # same orientation
        np.testing.assert_array_equal(np.sort(idx), want)  # each once
        np.testing.assert_array_equal(centres, c0[idx])
        np.testing.assert_array_equal(fl, fl0[idx])
    with pytest.raises(ValueError, match="out of range"):
        rdt.facets_around(np.array([len(rdt.samples())]))


def test_changed_facets_are_delaunay_facets_with_clipped_duals():
    rng = np.random.default_rng(3)
    rdt = _rdt_new(radius=1.5)
    rdt.insert(rng.uniform(-1, 1, (60, 3)))
    tri, seg, end_index, ends, rho, samples, *_ = rdt.changed_facets()
    assert np.all(tri[:, 0] < tri[:, 1]) and np.all(tri[:, 1] < tri[:, 2])
    assert len(np.unique(tri, axis=0)) == len(tri)
    assert np.all(rdt.is_facet(tri))
    # Each dual segment is clipped to the ball and equidistant from its facet.
    assert np.all(np.linalg.norm(seg, axis=2) <= 1.5 * (1 + 1e-12))
    P = rdt.samples()
    for end in (seg[:, 0], seg[:, 1]):
        d = np.linalg.norm(end[:, None, :] - P[tri], axis=2)
        assert np.allclose(d, d[:, :1], rtol=1e-8, atol=1e-12)
    # Segment ends index a table of distinct points (shared Voronoi vertices once).
    assert np.array_equal(ends[end_index], seg)
    assert len(np.unique(ends, axis=0)) == len(ends)
    assert len(ends) < 2 * len(tri)
    assert np.allclose(rho, circumradii(P[tri]), rtol=1e-9)
    # The samples are those of sample_segments with the smallest-id vertex as apex.
    again = _rdt.sample_segments(seg, P[tri[:, 0]], rho)
    for got, want in zip(samples, again, strict=True):
        assert np.array_equal(got, want)
    # After a full pass nothing changed any more.
    rdt.update_facets(np.zeros(len(tri), np.uint8), np.zeros((len(tri), 3)))
    assert len(rdt.changed_facets()[0]) == 0
    # all_facets lists the same facets.
    all_tri, all_seg = rdt.all_facets()
    order_a = np.lexsort(tri.T[::-1])
    order_b = np.lexsort(all_tri.T[::-1])
    assert np.array_equal(tri[order_a], all_tri[order_b])
    assert np.array_equal(seg[order_a], all_seg[order_b])


def test_neighbours_symmetric_and_cover_facet_edges():
    rng = np.random.default_rng(4)
    rdt = _rdt_new()
    rdt.insert(rng.uniform(-1, 1, (40, 3)))
    offsets, adj = rdt.neighbours(np.arange(40))
    nb = [set(adj[offsets[i] : offsets[i + 1]].tolist()) for i in range(40)]
    for i in range(40):
        assert i not in nb[i]
        assert all(i in nb[j] for j in nb[i])
    tri, _ = rdt.all_facets()
    for a, b in itertools.chain(tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [0, 2]]):
        assert b in nb[a]
    with pytest.raises(ValueError, match=r"out of range"):
        rdt.neighbours(np.array([40]))
    with pytest.raises(ValueError, match=r"out of range"):
        rdt.is_facet(np.array([[0, 1, 99]]))


# -- the incremental restricted set equals a from-scratch recomputation -----------


def _torus_sample(n, rng, R=1.0, r=0.4):
    u, v = rng.uniform(0, 2 * np.pi, (2, n))
    return np.column_stack(
        [(R + r * np.cos(v)) * np.cos(u), (R + r * np.cos(v)) * np.sin(u), r * np.sin(v)]
    )


def _sphere_sample(n, rng):
    p = rng.normal(size=(n, 3))
    return p / np.linalg.norm(p, axis=1)[:, None]


def _from_scratch(rdt, surface, criteria):
    """Restricted, bad and outward-oriented facets recomputed from all facets."""
    P = rdt.samples()
    tri, seg = rdt.all_facets()
    ev = evaluate_facets(surface, P[tri[:, 0]], seg, circumradii(P[tri]))
    return tri, seg, ev, ev.restricted, _bad(criteria, P[tri], ev)


def _bad(criteria, corners, ev):
    """Restricted facets failing a criterion or crossing several times/tangentially."""
    r = ev.restricted
    bad = np.zeros(len(corners), bool)
    bad[r] = (
        criteria.bad(corners[r], ev.centre[r], ev.radius[r])
        | (ev.n_cross[r] >= 2)
        | ev.tangential[r]
    )
    return bad


def _as_set(tri):
    return {tuple(t) for t in np.sort(tri, axis=1).tolist()}


def _drive_and_compare(surface, seeds, criteria, max_rounds=60, known=False):
    """A hand-written facet-stage loop; after every round the core's restricted
    set must equal a from-scratch recomputation. ``known``: mark clean facets
    KNOWN, so that the core derives their next status itself."""
    rdt = _rdt.RestrictedDelaunay(surface.centre, surface.radius)
    rdt.insert(seeds)
    rounds = 0
    for rounds in range(1, max_rounds + 1):  # noqa: B007
        P = rdt.samples()
        tri, seg, end_index, ends, rho, samples, *_ = rdt.changed_facets()
        assert np.allclose(rho, circumradii(P[tri]), rtol=1e-9)
        ev = evaluate_facets(
            surface, P[tri[:, 0]], seg, rho, surface(ends)[end_index], DualSamples(*samples)
        )
        r = ev.restricted
        bad = _bad(criteria, P[tri], ev)
        flags = r * RESTRICTED | bad * BAD | (r & ev.outward) * OUTWARD
        if known:
            flags |= ev.clean * KNOWN
        rdt.update_facets(flags.astype(np.uint8), ev.centre)
        rdt.check()

        out_tri, out_centre, _ = rdt.facets(0)
        bad_tri, bad_centre, _ = rdt.facets(BAD)
        s_tri, s_seg, s_ev, s_r, s_bad = _from_scratch(rdt, surface, criteria)
        assert _as_set(out_tri) == _as_set(s_tri[s_r])
        assert _as_set(bad_tri) == _as_set(s_tri[s_bad])
        assert len(_as_set(out_tri)) == len(out_tri)  # each facet reported once
        # Same surface centres (up to the root tolerance) and orientation:
        # the reported normal points along the dual segment iff the outside
        # lies in the segment's direction.
        key = {t: i for i, t in enumerate(map(tuple, s_tri.tolist()))}
        idx = np.array([key[tuple(t)] for t in np.sort(out_tri, axis=1).tolist()], dtype=np.int64)
        assert np.allclose(out_centre, s_ev.centre[idx], atol=1e-9, rtol=0)
        n = face_normals(P, out_tri)
        along = np.einsum("ij,ij->i", n, s_seg[idx, 1] - s_seg[idx, 0]) > 0
        assert np.array_equal(along, s_ev.outward[idx])

        if len(bad_tri) == 0:
            break
        radii = np.linalg.norm(bad_centre - P[bad_tri[:, 0]], axis=1)
        pick = _rdt.select_independent(bad_centre, radii)
        rdt.insert(bad_centre[pick])
    return rdt, rounds


@pytest.mark.parametrize("known", [False, True])
@pytest.mark.parametrize(
    ("name", "sample", "radius_bound"),
    [("sphere", _sphere_sample, 0.15), ("torus", _torus_sample, 0.08)],
)
def test_incremental_restricted_set_matches_recomputation(name, sample, radius_bound, known):
    surface = SURFACES[name].make()
    seeds = sample(300, np.random.default_rng(5))
    criteria = FacetCriteria(30.0, radius_bound)
    rdt, rounds = _drive_and_compare(surface, seeds, criteria, known=known)
    assert rounds > 3  # the comparison ran on several incremental rounds
    # With KNOWN flags the core derived many facets' status itself (and the
    # comparison above found it right); without them it never does.
    assert (rdt.reused_facets > 100) if known else (rdt.reused_facets == 0)
    assert len(rdt.facets(BAD)[0]) == 0
    assert rdt.number_of_samples > 2 * len(seeds)


# -- the batching rule ----------------------------------------------------------


def _greedy_reference(c, r):
    order = sorted(range(len(r)), key=lambda k: (-r[k], c[k, 0], c[k, 1], c[k, 2]))
    acc = []
    for k in order:
        inside = False
        for a in acc:
            e = c[k] - c[a]
            if e[0] * e[0] + e[1] * e[1] + e[2] * e[2] <= r[a] * r[a]:
                inside = True
                break
        if not inside:
            acc.append(k)
    return acc


def _random_balls(rng, kind, n):
    if kind == "continuous":
        return rng.uniform(-1, 1, (n, 3)), rng.uniform(0.01, 0.3, n)
    if kind == "multiscale":
        return rng.uniform(-1, 1, (n, 3)), 10.0 ** rng.uniform(-4, 0, n)
    if kind == "extreme":  # radii from 1e-300 to 1: hundreds of grid levels
        return rng.uniform(-1, 1, (n, 3)), 10.0 ** rng.uniform(-300, 0, n)
    # Ties: centres on a grid of exactly representable values, few radii, so
    # equal radii, equal coordinates and distances exactly equal to a radius
    # (closed ball: rejected) all occur.
    c = rng.integers(-4, 5, (n, 3)) * 0.25
    r = rng.choice([0.25, 0.5, 0.75], n)
    return c, r


@pytest.mark.parametrize("kind", ["continuous", "multiscale", "extreme", "ties"])
@pytest.mark.parametrize("seed", range(4))
def test_select_independent_equals_greedy(kind, seed):
    rng = np.random.default_rng(100 + seed)
    c, r = _random_balls(rng, kind, 300)
    got = _rdt.select_independent(c, r)
    ref = _greedy_reference(c, r)
    # Same balls in the same order (exactly repeated balls are interchangeable).
    assert len(got) == len(ref)
    assert np.array_equal(c[got], c[ref]) and np.array_equal(r[got], r[ref])
    if kind != "ties":
        assert got.tolist() == ref
    # Independent: no accepted centre lies in another accepted ball.
    acc = c[got]
    d = np.linalg.norm(acc[:, None] - acc[None], axis=2)
    rmax = np.maximum(r[got][:, None], r[got][None, :])
    off = ~np.eye(len(got), dtype=bool)
    assert np.all(d[off] > rmax[off])
    # Maximal: every rejected centre lies in an accepted ball at least as large.
    rejected = np.setdiff1d(np.arange(len(r)), got)
    dr = np.linalg.norm(c[rejected][:, None] - acc[None], axis=2)
    covers = (dr <= r[got][None, :]) & (r[got][None, :] >= r[rejected][:, None])
    assert np.all(covers.any(axis=1))


def test_select_independent_duplicates_and_order():
    c = np.array([[0.0, 0, 0], [0.0, 0, 0], [1.0, 0, 0], [0.5, 0, 0]])
    r = np.array([0.2, 0.2, 0.6, 0.1])
    # Largest first; ball 3 is inside ball 2 (distance 0.5 <= 0.6); of the two
    # identical balls the first (lexicographic tie, then stable) is kept once.
    got = _rdt.select_independent(c, r).tolist()
    assert got[0] == 2
    assert len(got) == 2 and got[1] in (0, 1)
    assert _rdt.select_independent(np.zeros((0, 3)), np.zeros(0)).shape == (0,)


@pytest.mark.parametrize(
    ("radii", "match"),
    [
        pytest.param([0.1, 0.0], r"positive radius", id="zero"),
        pytest.param([0.1, -0.1], r"positive radius", id="negative"),
        pytest.param([np.nan, 0.1], r"positive radius", id="nan"),
        pytest.param([np.inf, 0.1], r"positive radius", id="inf"),
        pytest.param([0.1], r"matching", id="length"),
    ],
)
def test_select_independent_bad_radii(radii, match):
    c = np.array([[0.0, 0, 0], [1.0, 0, 0]])
    with pytest.raises(ValueError, match=match):
        _rdt.select_independent(c, np.array(radii))


def test_select_independent_bad_centres():
    with pytest.raises(ValueError, match=r"finite centre"):
        _rdt.select_independent(np.array([[0.0, np.nan, 0]]), np.array([0.1]))
    with pytest.raises(ValueError, match=r"shape \(n, 3\)"):
        _rdt.select_independent(np.zeros((2, 2)), np.ones(2))


# -- chunked changed facets -------------------------------------------------------


def _sphere_points(n, seed):
    p = np.random.default_rng(seed).normal(size=(n, 3))
    return p / np.linalg.norm(p, axis=1)[:, None]


def _drain(rdt, max_facets):
    """All chunks of a round, updating each with 'restricted' flags."""
    seen = []
    while True:
        tri, seg, ei, ends, rho, *_ = rdt.changed_facets(max_facets)
        if len(tri) == 0:
            return seen
        assert len(tri) <= max_facets + 12  # a chunk ends with its last cell
        assert np.array_equal(ends[ei[:, 0]], seg[:, 0])
        assert np.array_equal(ends[ei[:, 1]], seg[:, 1])
        rdt.update_facets(np.full(len(tri), RESTRICTED | OUTWARD, np.uint8), seg[:, 0])
        seen.append(tri)


def test_chunks_cover_the_same_facets_as_one_call():
    pts = _sphere_points(3000, 1)
    one = _rdt_new()
    one.insert(pts)
    whole = one.changed_facets()[0]
    many = _rdt_new()
    many.insert(pts)
    chunks = _drain(many, 500)
    assert len(chunks) > 3
    joined = np.concatenate(chunks)
    assert len(_as_set(joined)) == len(joined)  # no facet twice
    assert _as_set(joined) == _as_set(whole)
    # Every restricted facet was updated: the complex has them all, once.
    assert _as_set(many.facets(0)[0]) == _as_set(whole)
    many.check()


def test_chunks_are_updated_oldest_first():
    rdt = _rdt_new()
    rdt.insert(_sphere_points(500, 2))
    first = rdt.changed_facets(100)[0]
    second = rdt.changed_facets(100)[0]
    assert not _as_set(first) & _as_set(second)
    wrong = len(first) + len(second) + 1
    with pytest.raises(ValueError, match="oldest chunk"):
        rdt.update_facets(np.zeros(wrong, np.uint8), np.zeros((wrong, 3)))
    flag = np.uint8(RESTRICTED | OUTWARD)
    rdt.update_facets(np.full(len(first), flag), np.zeros((len(first), 3)))
    rdt.update_facets(np.full(len(second), flag), np.zeros((len(second), 3)))
    assert _as_set(rdt.facets(0)[0]) == _as_set(first) | _as_set(second)


def test_unfinished_round_is_reported_again_after_insert():
    rdt = _rdt_new()
    pts = _sphere_points(2000, 3)
    rdt.insert(pts[:1000])
    rdt.changed_facets(200)  # leave the round unfinished, never updated
    rdt.insert(pts[1000:])
    _drain(rdt, 10**9)
    # Compare with a from-scratch pass: every facet whose dual meets the ball.
    all_tri = rdt.all_facets()[0]
    assert _as_set(rdt.facets(0)[0]) == _as_set(all_tri)


def test_restart_round_hands_out_the_whole_round_again():
    rdt = _rdt_new()
    pts = _sphere_points(1500, 4)
    rdt.insert(pts)
    tri, *_ = rdt.changed_facets(300)
    rdt.update_facets(np.full(len(tri), RESTRICTED | OUTWARD, np.uint8), np.zeros((len(tri), 3)))
    rdt.changed_facets(300)  # interrupted: handed out, never updated
    rdt.restart_round()
    again = np.concatenate(_drain(rdt, 300))
    assert _as_set(tri) <= _as_set(again)
    assert _as_set(rdt.facets(0)[0]) == _as_set(rdt.all_facets()[0])
    rdt.check()


# -- samples along dual segments ---------------------------------------------------


def test_sample_segments_layout_and_spacing():
    """Samples run from 0 to each segment's length, interior points lie on the
    segment, and neighbouring samples are about one empty-ball radius apart."""
    rng = np.random.default_rng(8)
    k = 400
    tri_pts = rng.normal(size=(k, 3, 3))
    a, b, c = tri_pts[:, 0], tri_pts[:, 1], tri_pts[:, 2]
    rho = circumradii(tri_pts)
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1)[:, None]
    # Circumcentre of each triangle, and a segment along its normal line.
    ab, ac = b - a, c - a
    cc = (
        a
        + (
            np.cross(np.cross(ab, ac), ab) * np.einsum("ij,ij->i", ac, ac)[:, None]
            + np.cross(ac, np.cross(ab, ac)) * np.einsum("ij,ij->i", ab, ab)[:, None]
        )
        / (2 * np.einsum("ij,ij->i", np.cross(ab, ac), np.cross(ab, ac)))[:, None]
    )
    t0, t1 = np.sort(rng.uniform(-20, 20, (2, k)) * rho, axis=0)
    seg = np.stack([cc + t0[:, None] * n, cc + t1[:, None] * n], axis=1)
    offsets, s, interior = _rdt.sample_segments(seg, a, rho, per_radius=2.0, max_intervals=200)
    counts = np.diff(offsets)
    length = np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1)
    assert offsets[0] == 0 and offsets[-1] == len(s)
    assert np.all(counts >= 4)  # at least min_intervals = 3 intervals
    assert len(interior) == len(s) - 2 * k
    seg_of = np.repeat(np.arange(k), counts)
    assert np.all(s[offsets[:-1]] == 0) and np.allclose(s[offsets[1:] - 1], length)
    steps = np.diff(s)[seg_of[1:] == seg_of[:-1]]
    assert np.all(steps >= 0)
    # Interior points are start + s * unit direction.
    inner = np.ones(len(s), bool)
    inner[offsets[:-1]] = inner[offsets[1:] - 1] = False
    u = (seg[:, 1] - seg[:, 0]) / length[:, None]
    want = seg[seg_of[inner], 0] + s[inner, None] * u[seg_of[inner]]
    assert np.allclose(interior, want, atol=1e-12)
    # Spacing: 2 samples per unit of asinh(sigma / rho), so a gap is at most
    # 0.5 x the larger ball radius, which is at most e^0.5 x the nearer one.
    sigma = t0[seg_of] + s  # distance from the circumcentre along the line
    ball = np.sqrt(rho[seg_of] ** 2 + sigma**2)
    gap = np.diff(s)
    same = seg_of[1:] == seg_of[:-1]
    near_ball = np.minimum(ball[1:], ball[:-1])[same]
    assert np.all(gap[same] <= 0.5 * np.exp(0.5) * near_ball * (1 + 1e-9))


def test_sample_points_have_the_bits_of_numpys():
    """The core's interior points are start + s u with u from
    segment_directions, bit for bit: the root search evaluates f at those
    points and takes the samples' values for them. Segments from 1e-9 to 1e4
    long, some with a zero coordinate, and one of zero length."""
    rng = np.random.default_rng(3)
    k = 3000
    start = rng.normal(size=(k, 3)) * 10.0 ** rng.uniform(-3, 3, (k, 1))
    d = rng.normal(size=(k, 3)) * 10.0 ** rng.uniform(-9, 4, (k, 1))
    d[::7, 1] = 0.0
    d[0] = 0.0
    seg = np.stack([start, start + d], axis=1)
    size = np.abs(d).max(axis=1) + 1e-12
    apex = start + rng.normal(size=(k, 3)) * size[:, None]
    rho = 0.05 * size
    offsets, s, interior = _rdt.sample_segments(seg, apex, rho)
    length, u = segment_directions(seg[:, 1] - seg[:, 0])
    counts = np.diff(offsets)
    owner = np.repeat(np.arange(k), counts - 2)
    inner = np.ones(len(s), bool)
    inner[offsets[:-1]] = inner[offsets[1:] - 1] = False
    expected = seg[owner, 0] + s[inner][:, None] * u[owner]
    assert len(interior) > 3 * k
    assert np.array_equal(interior, expected)
    assert np.array_equal(s[offsets[1:] - 1], length)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"per_radius": 0.0}, "per_radius"),
        ({"min_intervals": 0}, "min_intervals"),
        ({"min_intervals": 5, "max_intervals": 4}, "max_intervals"),
    ],
)
def test_sample_segments_rejects_bad_spec(kwargs, match):
    seg = np.zeros((1, 2, 3))
    seg[0, 1, 0] = 1.0
    with pytest.raises(ValueError, match=match):
        _rdt.sample_segments(seg, np.zeros((1, 3)), np.ones(1), **kwargs)


def test_sample_segments_rejects_bad_shapes():
    with pytest.raises(ValueError, match="seg"):
        _rdt.sample_segments(np.zeros((2, 3)), np.zeros((2, 3)), np.ones(2))
    with pytest.raises(ValueError, match="apex"):
        _rdt.sample_segments(np.zeros((2, 2, 3)), np.zeros((3, 3)), np.ones(2))
    with pytest.raises(ValueError, match="rho"):
        _rdt.sample_segments(np.zeros((2, 2, 3)), np.zeros((2, 3)), np.ones(3))
    bad = np.zeros((1, 2, 3))
    bad[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        _rdt.sample_segments(bad, np.zeros((1, 3)), np.ones(1))


def _nearly_cocircular_cloud():
    """A square grid in a tilted plane (rounded, so its quadruples are nearly
    coplanar and nearly cocircular, as regular samples are) between two
    sparser layers: many nearly flat cells."""
    g = np.stack(np.meshgrid(np.arange(-6, 7), np.arange(-6, 7)), -1).reshape(-1, 2) * 0.05
    a = np.radians(17.0)
    rot = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    plane = np.c_[g, np.zeros(len(g))] @ rot.T
    n = rot @ np.array([0.0, 0.0, 1.0])
    return np.r_[plane, plane[::7] + 0.2 * n, plane[::5] - 0.25 * n]


def test_voronoi_vertices_are_equidistant_from_their_samples_on_nearly_flat_cells():
    # CGAL's filtered circumcentre only checks that the centre lies inside the
    # sphere: on such cells it was off by up to 38 % of the radius.
    rdt = _rdt.RestrictedDelaunay(np.zeros(3), 1.0)
    rdt.insert(_nearly_cocircular_cloud())
    p = rdt.samples()
    tri, _, end_index, ends, *_ = rdt.changed_facets(0)
    checked = 0
    for side in range(2):
        e = ends[end_index[:, side]]
        vor = np.linalg.norm(e, axis=1) < 1 - 1e-9  # not an end clipped at the sphere
        d = np.linalg.norm(e[vor, None, :] - p[tri[vor]], axis=2)
        assert ((d.max(1) - d.min(1)) / d.max(1)).max() <= 1e-12
        checked += int(vor.sum())
    assert checked > 1000
