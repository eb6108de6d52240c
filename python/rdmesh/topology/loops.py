"""T2 loop test: closed loops and folded arcs of the surface inside Voronoi facets.

The Voronoi facet ``F_pq`` dual to a Delaunay edge ``pq`` is a convex polygon
in the bisector plane of ``p`` and ``q`` (from the C++ core, ``voronoi_facets``).
The topological ball property needs ``F ∩ Σ`` to be empty or one arc. The
crossing count (:func:`rdmesh.topology.voronoi_facet_test`) sees the arcs that
reach the boundary; this module looks for what it cannot see: a closed loop
(``k = 0`` or ``k = 2`` boundary crossings) and an arc that turns back.

In the plane take ``e1`` along the chord between the two boundary crossings
(any in-plane direction when ``k = 0``) and ``e2 = n × e1``. A closed loop has a
maximum of ``<x, e1>`` along it, a point with ``f = 0`` and ``<∇f, e2> = 0``;
an arc monotone along its chord has none. The system is solved by damped 2-D
Newton (directional Hessians by differences of the gradient) from a few seeds
per facet, all facets at once: one call of ``f`` and one of the gradient per
iteration. A solution strictly inside the polygon is a violation (a loop, or
an arc that folds back, which needs a facet coarse against the surface).

Which facets, and which seeds:

* Facets of complex edges (2 crossings ``a``, ``b``, the surface centres of
  the edge's two restricted facets). The gradients at ``a`` and ``b`` give
  the arc's direction along the chord at its ends: opposite directions mean
  a fold (a violation without Newton). A facet whose arc leaves both ends
  within 60 degrees of the chord, in the same direction, and for which
  ``<∇f, e2>`` interpolated linearly from ``a`` to ``b`` predicts no turn
  within one chord length of the chord's midpoint gets no seed (and its
  polygon is not even built). The others are seeded at that predicted turn
  (when inside the polygon) and, when an end leaves the chord at more than
  60 degrees, at the chord's quarter points and the polygon's centroid.
* Facets without crossings, only where a probe on the surface lies within
  the probe spacing of the facet, its two nearest samples being ``p`` and
  ``q``; seeds: that probe and the centroid. Without probes none is tested.

Sampled: a loop or fold missed by every seed is not seen.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .._newton import damped_step
from .._tol import (
    DIRECTION_EPS,
    LOOP_F_TOL,
    LOOP_G_TOL,
    LOOP_SINGULAR,
    LOOP_STEP,
    POLYGON_EPS,
    TINY,
)
from .._vectors import row_norms
from ..surfaces.oracle import forward_gradient
from .complex import ComplexStatus

#: Newton iterations per seed (seeds leave early when they converge or stray).
ITERATIONS = 8
#: Cosine of the largest angle between the arc and its chord at both ends for
#: which a facet of a complex edge counts as running along its chord (no
#: quarter-point and centroid seeds).
MONOTONE_COS = 0.5
#: Complex edges screened at a time (bounds the test's memory).
SCREEN_CHUNK = 1 << 14
#: Points whose gradient is evaluated at a time by the screen.
GRAD_CHUNK = 1 << 16
#: A seed whose full Newton step exceeds this many polygon diameters is dropped.
STRAY = 0.5


@dataclass
class LoopMemo:
    """Facets found clean, by edge and fingerprint, plus cost counters.

    The fingerprint of a complex edge's facet is its two crossings, of another
    facet its polygon: a facet whose fingerprint did not change since it was
    found clean is not tested again (the surface is fixed).
    """

    keys: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    prints: np.ndarray = field(default_factory=lambda: np.zeros(0))
    seconds: float = 0.0
    tested: int = 0

    def known(self, keys: np.ndarray, prints: np.ndarray) -> np.ndarray:
        if len(self.keys) == 0 or len(keys) == 0:
            return np.zeros(len(keys), bool)
        i = np.minimum(np.searchsorted(self.keys, keys), len(self.keys) - 1)
        return (self.keys[i] == keys) & (self.prints[i] == prints)

    def remember(self, keys: np.ndarray, prints: np.ndarray) -> None:
        """Add ``keys`` with their ``prints``; a key already known takes the
        new print, and of a key given twice the first print counts."""
        if len(keys) == 0:
            return
        # Sorted and merged, not concatenated with the memo and sorted again:
        # the merge sets the peak memory of the report's loop test. Keys of
        # complex edges come sorted and distinct: no sort then.
        if len(keys) > 1 and not np.all(keys[1:] > keys[:-1]):
            o = np.argsort(keys, kind="stable")
            keys, prints = keys[o], prints[o]
            del o
            first = np.empty(len(keys), bool)
            first[:1] = True
            np.not_equal(keys[1:], keys[:-1], out=first[1:])
            keys, prints = keys[first], prints[first]
            del first
        old = np.ones(len(self.keys), bool)
        old[_find(self.keys, keys)] = False
        kept = self.keys[old]
        # Destinations of the new entries in the merged order; the old ones
        # that stay fill the rest, in their order.
        at = np.searchsorted(kept, keys) + np.arange(len(keys))
        rest = np.ones(len(keys) + len(kept), bool)
        rest[at] = False
        merged_keys = np.empty(len(rest), np.result_type(self.keys, keys))
        merged_keys[at] = keys
        merged_keys[rest] = kept
        del kept
        merged_prints = np.empty(len(rest), np.result_type(self.prints, prints))
        merged_prints[at] = prints
        merged_prints[rest] = self.prints[old]
        self.keys, self.prints = merged_keys, merged_prints


@dataclass
class LoopViolations:
    """Facets with a loop or fold: edge ids and the refinement points."""

    edges: np.ndarray  # (v, 2)
    centres: np.ndarray  # (c, 3)
    radii: np.ndarray  # (c,)


def loop_test(
    surface, rdt, vertices, tri, centres, status: ComplexStatus, probes=None, tree=None, memo=None
):
    """Voronoi facets of the sample set meeting the surface in a loop or folded arc.

    Parameters
    ----------
    surface : the implicit surface.
    rdt : the C++ core (``voronoi_facets``, ``delaunay_edges``).
    vertices : (n, 3) samples.
    tri : (F, 3) restricted facets; centres : (F, 3) their surface centres.
    status : :func:`rdmesh.complex.complex_status` of ``tri``.
    probes : :class:`rdmesh.topology.Probes` or None; facets without boundary
        crossings are tested where a probe lies within the probe spacing of
        them (between its two nearest samples), none without probes.
    tree : cKDTree of ``vertices`` or None.
    memo : :class:`LoopMemo` or None; facets unchanged since found clean are skipped.

    Returns
    -------
    LoopViolations
        For each failing facet one refinement point, the point of ``F ∩ Σ``
        found farthest from ``p`` (a solution or a boundary crossing): it lies
        in ``F``, so no sample is nearer than ``p`` and it is the centre of an
        empty ball of radius ``|x - p|``.
    """
    t0 = time.perf_counter()
    memo = memo if memo is not None else LoopMemo()
    n = max(len(vertices), 1)
    # Complex edges with 2 crossings: their restricted facets' centres. Other
    # non-zero counts are the crossing-count test's.
    pos = np.flatnonzero(status.edge_count == 2)
    fa_all, fb_all = _crossing_facets(status, len(tri))
    fa_all, fb_all = fa_all[pos], fb_all[pos]
    need = np.zeros(len(tri), bool)
    need[fa_all] = need[fb_all] = True
    slot = np.cumsum(need, dtype=np.int32)
    slot -= 1
    g = _gradients(surface, centres, np.flatnonzero(need))
    # Screen in chunks: the temporaries of all complex edges at once would
    # dominate the peak memory of a large run.
    rests, plain_keys, plain_prints = [], [], []
    for lo in range(0, len(pos), SCREEN_CHUNK):
        sl = slice(lo, lo + SCREEN_CHUNK)
        key = status.edge_key[pos[sl]]
        e2 = np.column_stack([key // n, key % n])
        fa, fb = fa_all[sl], fb_all[sl]
        a, b = centres[fa], centres[fb]
        keys2 = (e2[:, 0] << 32) | e2[:, 1]
        prints2 = a @ _W + b @ (2 * _W) + 1.0
        fresh2 = ~memo.known(keys2, prints2)
        e2, fa, fb, a, b = e2[fresh2], fa[fresh2], fb[fresh2], a[fresh2], b[fresh2]
        keys2, prints2 = keys2[fresh2], prints2[fresh2]
        ga, gb = g[slot[fa]], g[slot[fb]]
        # Facets whose arc evidently runs along its chord need no polygon and
        # no Newton (see _screen).
        plain = _screen(vertices, e2, a, b, ga, gb)
        plain_keys.append(keys2[plain])
        plain_prints.append(prints2[plain])
        rest = ~plain
        rests.append((e2[rest], a[rest], b[rest], ga[rest], gb[rest], prints2[rest]))
    del pos, fa_all, fb_all, need, slot, g
    n_plain = sum(len(k) for k in plain_keys)
    if plain_keys:
        # The chunks go before the memo merges: this merge sets the test's peak.
        k, p = np.concatenate(plain_keys), np.concatenate(plain_prints)
        del plain_keys, plain_prints
        memo.remember(k, p)
        del k, p
    if rests:
        e2, a, b, ga, gb, prints2 = (np.concatenate(c) for c in zip(*rests, strict=True))
    else:
        e2, a, b, ga, gb = np.zeros((0, 2), np.int64), *(np.zeros((0, 3)),) * 4
        prints2 = np.zeros(0)
    e0, seeds0 = np.zeros((0, 2), np.int64), np.zeros((0, 3))
    if probes is not None and len(probes.points) and len(vertices) >= 2:
        e0, seeds0 = _probe_edges(vertices, probes, tree)
        # Not complex edges (those have crossings), and Delaunay edges.
        keep = ~_sorted_has(status.edge_key, e0[:, 0] * n + e0[:, 1])
        e0, seeds0 = e0[keep], seeds0[keep]
        if len(e0):
            de = rdt.delaunay_edges(np.unique(e0[:, 0]))
            keep = _sorted_has(de[:, 0] * n + de[:, 1], e0[:, 0] * n + e0[:, 1])
            e0, seeds0 = e0[keep], seeds0[keep]
    edges = np.concatenate([e2, e0]).astype(np.int64)
    m2 = len(e2)
    k2 = np.arange(len(edges)) < m2
    pad = np.zeros((len(e0), 3))
    a, b = np.concatenate([a, pad]), np.concatenate([b, pad])
    ga, gb = np.concatenate([ga, pad]), np.concatenate([gb, pad])
    seeds = np.concatenate([np.full((m2, 3), np.nan), seeds0])
    keys = (edges[:, 0] << 32) | edges[:, 1]
    off, pts, _, _ = rdt.voronoi_facets(edges)
    # Facets without crossings: fingerprint the polygon's vertices.
    w = pts @ _W + 1.4142135623 * pts[:, 0] ** 2
    prints = (np.add.reduceat(w, off[:-1]) if len(pts) else np.zeros(0)) + np.diff(off)
    prints[:m2] = prints2
    fresh = k2 | ~memo.known(keys, prints)
    bad, x, r = _test(surface, vertices, edges, k2, a, b, ga, gb, off, pts, fresh, seeds)
    clean = fresh.copy()
    clean[bad] = False
    memo.remember(keys[clean], prints[clean])
    memo.tested += int(n_plain + fresh.sum())
    memo.seconds += time.perf_counter() - t0
    return LoopViolations(edges[bad], x, r)


def _find(table: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """Indices in the sorted array ``table`` of the ``keys`` that occur in it."""
    if len(table) == 0:
        return np.zeros(0, np.int64)
    i = np.minimum(np.searchsorted(table, keys), len(table) - 1)
    return i[table[i] == keys]


def _sorted_has(table: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """Whether each key occurs in the sorted array ``table``."""
    if len(table) == 0:
        return np.zeros(len(keys), bool)
    i = np.minimum(np.searchsorted(table, keys), len(table) - 1)
    return table[i] == keys


#: A fixed direction for fingerprints.
_W = np.array([0.5772156649, 0.2718281828, 0.3141592653])


def _crossing_facets(status, n_facets):
    """For each edge of the complex, its smallest and largest facet index
    (the two restricted facets of an edge with 2)."""
    f_of = np.arange(n_facets, dtype=np.int32)
    first = np.full(len(status.edge_key), n_facets, np.int32)
    last = np.full(len(status.edge_key), -1, np.int32)
    # A column at a time: no (F, 3) copies of the facets' edges.
    for j in range(3):
        fe = status.facet_edges[:, j]
        np.minimum.at(first, fe, f_of)
        np.maximum.at(last, fe, f_of)
    return first, last


def _gradients(surface, points, rows):
    """``surface.grad(points[rows])``, in chunks of :data:`GRAD_CHUNK` rows
    (the gradient's temporaries for every facet at once would set the
    test's peak memory); forward differences without a gradient function
    (the screen and Newton's seeds need no more)."""
    g = np.empty((len(rows), 3))
    for lo in range(0, len(rows), GRAD_CHUNK):
        g[lo : lo + GRAD_CHUNK] = forward_gradient(surface, points[rows[lo : lo + GRAD_CHUNK]])
    return g


def _end_slopes(ga, gb, e2):
    """``<grad f, e2>`` at the crossings ``a`` and ``b``, and its cosine with
    the gradient (how closely the arc follows the chord there)."""
    sa, sb = np.einsum("ij,ij->i", ga, e2), np.einsum("ij,ij->i", gb, e2)
    ca = np.abs(sa) / np.maximum(row_norms(ga), TINY)
    cb = np.abs(sb) / np.maximum(row_norms(gb), TINY)
    return sa, sb, ca, cb


def _screen(vertices, edges, a, b, ga, gb):
    """Complex edges whose facet arc evidently runs along its chord ``ab``.

    True where the arc leaves both crossings within 60 degrees of the chord,
    in the same direction along it, and ``<grad f, e2>`` interpolated linearly
    from ``a`` to ``b`` vanishes (a predicted turn) no nearer than one chord
    length to the chord's midpoint. Such facets get no Newton seeds.
    """
    if len(edges) == 0:
        return np.zeros(0, bool)
    nrm = vertices[edges[:, 1]] - vertices[edges[:, 0]]
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    e1 = b - a
    e1 -= np.einsum("ij,ij->i", e1, nrm)[:, None] * nrm
    length = np.linalg.norm(e1, axis=1)
    e2 = np.cross(nrm, e1 / np.maximum(length, TINY)[:, None])
    sa, sb, ca, cb = _end_slopes(ga, gb, e2)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = sa / (sa - sb)
    far = ~(np.abs(t - 0.5) <= 1.0)  # NaN (no turn) counts as far
    same_way = np.sign(sa) * np.sign(sb) > 0
    return same_way & (np.minimum(ca, cb) >= MONOTONE_COS) & far & (length > 0)


def _probe_edges(vertices, probes, tree):
    """Edges ``pq`` (sorted) whose bisector plane passes within the probe spacing
    of a probe whose two nearest samples are ``p`` and ``q``; the probe nearest
    each such plane as a seed."""
    from scipy.spatial import cKDTree

    tree = tree or cKDTree(vertices)
    d, idx = tree.query(probes.points, k=2)
    p, q = vertices[idx[:, 0]], vertices[idx[:, 1]]
    gap = (d[:, 1] ** 2 - d[:, 0] ** 2) / (2 * np.maximum(np.linalg.norm(q - p, axis=1), TINY))
    near = np.flatnonzero(gap < probes.spacing)
    if near.size == 0:
        return np.zeros((0, 2), np.int64), np.zeros((0, 3))
    e = np.sort(idx[near], axis=1).astype(np.int64)
    order = np.lexsort((gap[near], e[:, 1], e[:, 0]))
    e = e[order]
    first = np.r_[True, np.any(e[1:] != e[:-1], axis=1)]
    return e[first], probes.points[near[order][first]]


def _test(surface, vertices, edges, is2, a, b, ga, gb, off, pts, fresh, seeds):
    """Rows of ``edges`` that fail, with one refinement point each."""
    none = (np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0))
    rows = np.flatnonzero(fresh)
    if rows.size == 0:
        return none
    p, q = vertices[edges[rows, 0]], vertices[edges[rows, 1]]
    nrm = q - p
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    # Sub-CSR of the fresh polygons.
    sizes = np.diff(off)[rows]
    sub_off = np.r_[0, np.cumsum(sizes)]
    idx = np.repeat(off[rows] - sub_off[:-1], sizes) + np.arange(sub_off[-1])
    poly = pts[idx]
    owner = np.repeat(np.arange(len(rows)), sizes)
    centroid = np.add.reduceat(poly, sub_off[:-1]) / sizes[:, None]
    radius = np.zeros(len(rows))
    np.maximum.at(radius, owner, np.linalg.norm(poly - centroid[owner], axis=1))
    diam = 2.0 * radius
    k2 = is2[rows]
    a, b, ga, gb = a[rows], b[rows], ga[rows], gb[rows]
    # Plane frames: e1 along the chord (k = 2), else any in-plane direction.
    e1 = b - a
    e1 -= np.einsum("ij,ij->i", e1, nrm)[:, None] * nrm
    l1 = np.linalg.norm(e1, axis=1)
    helper = np.where(np.abs(nrm[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    alt = np.cross(nrm, helper)
    e1 = np.where((l1 > DIRECTION_EPS * diam)[:, None], e1, alt)
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(nrm, e1)
    # The arc's direction along the chord is sign(<grad f, e2>) (the tangent
    # is n x grad f): opposite signs at a and b mean the arc turns back.
    sa, sb, ca, cb = _end_slopes(ga, gb, e2)
    fold = k2 & (np.sign(sa) * np.sign(sb) < 0)
    straight = k2 & (np.minimum(ca, cb) >= MONOTONE_COS)
    # Chord seed: where <grad f, e2>, interpolated linearly from a to b,
    # vanishes (the turn the ends predict), if that lies within the polygon.
    with np.errstate(divide="ignore", invalid="ignore"):
        t = sa / (sa - sb)
        turn = a + t[:, None] * (b - a)
    chord = k2 & ~fold & np.isfinite(t)
    chord &= np.linalg.norm(turn - centroid, axis=1) <= radius
    # Seeds: the chord turn; for k = 2 facets whose arc leaves an end at more
    # than 60 degrees from the chord, the chord's quarter points and the
    # centroid; for k = 0 facets, the centroid and the probe.
    mc = np.flatnonzero(chord)
    bent = np.flatnonzero(k2 & ~fold & ~straight)
    mm = np.flatnonzero((k2 & ~fold & ~straight) | ~k2)
    mp = np.flatnonzero(~k2 & np.isfinite(seeds[rows, 0]))
    quarter = [a[bent] + u * (b[bent] - a[bent]) for u in (0.25, 0.5, 0.75)]
    srow = np.concatenate([mc, bent, bent, bent, mm, mp])
    x = np.concatenate([turn[mc], *quarter, centroid[mm], seeds[rows[mp]]])
    # Into the facet planes (the bisectors of p and q).
    mid = 0.5 * (p + q)[srow]
    x -= np.einsum("ij,ij->i", x - mid, nrm[srow])[:, None] * nrm[srow]
    sol_row, sol_x = _newton(surface, x, srow, nrm, e1, e2, centroid, diam)
    inside = _in_polygon(sol_x, sol_row, sub_off, poly, nrm, diam)
    sol_row, sol_x = sol_row[inside], sol_x[inside]
    bad = np.zeros(len(rows), bool)
    bad[sol_row] = True
    bad |= fold
    # Refinement point: farthest from p of the solutions and crossings.
    fr = np.flatnonzero(bad & k2)
    cand_row = np.concatenate([sol_row, fr, fr])
    cand_x = np.concatenate([sol_x, a[fr], b[fr]])
    if cand_row.size == 0:
        return none
    r = np.linalg.norm(cand_x - p[cand_row], axis=1)
    o = np.lexsort((r, cand_row))
    last = np.r_[cand_row[o][1:] != cand_row[o][:-1], True]
    pick = o[last]
    return rows[np.flatnonzero(bad)], cand_x[pick], r[pick]


def _newton(surface, x, row, nrm, e1, e2, centroid, diam):
    """Damped Newton on ``{f = 0, <grad f, e2> = 0}`` in each seed's facet plane.

    Returns the converged seeds: ``(row (s,), x (s, 3))``.
    """
    done_r, done_x = [], []
    for it in range(ITERATIONS + 1):
        if len(x) == 0:
            break
        u, v, n_ = e1[row], e2[row], nrm[row]
        h = LOOP_STEP * diam[row]
        f = surface(x)
        g3 = surface.grad(np.concatenate([x, x + h[:, None] * u, x + h[:, None] * v]))
        g3 = g3.reshape(3, len(x), 3)
        g = g3[0]
        g1 = np.einsum("ij,ij->i", g, u)
        g2 = np.einsum("ij,ij->i", g, v)
        gn = np.maximum(row_norms(g - np.einsum("ij,ij->i", g, n_)[:, None] * n_), TINY)
        ok = (np.abs(f) <= LOOP_F_TOL * diam[row] * gn) & (np.abs(g2) <= LOOP_G_TOL * gn)
        if ok.any():
            done_r.append(row[ok])
            done_x.append(x[ok])
        if it == ITERATIONS:
            break
        # Jacobian of (f, g2) in the plane coordinates (s along e1, t along e2).
        j21 = np.einsum("ij,ij->i", g3[1] - g, v) / h
        j22 = np.einsum("ij,ij->i", g3[2] - g, v) / h
        j11, j12 = g1, g2
        det = j11 * j22 - j12 * j21
        scale = np.abs(j11 * j22) + np.abs(j12 * j21)
        solvable = np.abs(det) > LOOP_SINGULAR * np.maximum(scale, TINY)
        det = np.where(solvable, det, 1.0)
        ds = -(j22 * f - j12 * g2) / det
        dt = -(-j21 * f + j11 * g2) / det
        step = ds[:, None] * u + dt[:, None] * v
        x, length = damped_step(x, step, 0.25 * diam[row])
        # A full step beyond the polygon's size: no solution near this seed.
        solvable &= length <= STRAY * diam[row]
        # Stray seeds leave: far outside their polygon, or no step.
        stay = ~ok & solvable & (np.linalg.norm(x - centroid[row], axis=1) <= 0.5 * diam[row])
        x, row = x[stay], row[stay]
    if not done_r:
        return np.zeros(0, np.int64), np.zeros((0, 3))
    return np.concatenate(done_r), np.concatenate(done_x)


def _in_polygon(x, row, sub_off, poly, nrm, diam):
    """Whether each point lies strictly inside its row's convex polygon."""
    if len(x) == 0:
        return np.zeros(0, bool)
    sizes = np.diff(sub_off)
    cnt = sizes[row]
    which = np.repeat(np.arange(len(x)), cnt)
    j = np.repeat(sub_off[row] - np.r_[0, np.cumsum(cnt)[:-1]], cnt) + np.arange(cnt.sum())
    start = sub_off[row][which]
    jn = start + (j - start + 1) % cnt[which]
    v0, v1 = poly[j], poly[jn]
    n_ = nrm[row][which]
    side = np.einsum("ij,ij->i", np.cross(v1 - v0, x[which] - v0), n_)
    edge_len = np.linalg.norm(v1 - v0, axis=1)
    dist = side / np.maximum(edge_len, TINY)
    eps = POLYGON_EPS * diam[row][which]
    real = edge_len > eps
    not_pos = np.bincount(which, weights=(dist <= eps) & real, minlength=len(x))
    not_neg = np.bincount(which, weights=(dist >= -eps) & real, minlength=len(x))
    return (not_pos == 0) | (not_neg == 0)
