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

Sampled: a loop or fold missed by every seed is not seen. Facets without
boundary crossings are tested only where a polygon vertex lies within one
polygon diameter of the surface to first order (``|f| / |∇f|`` in the plane).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .complex import ComplexStatus

#: Newton iterations per seed (seeds leave early when they converge or stray).
ITERATIONS = 8
#: Cosine of the largest angle between the arc and its chord at both ends for
#: which a facet gets only the chord seed (the arc enters and leaves along
#: the chord); others also get the centroid seed.
MONOTONE_COS = 0.5
#: A seed whose full Newton step exceeds this many polygon diameters is dropped.
STRAY = 1.0


@dataclass
class LoopMemo:
    """Facets found clean, by edge and polygon fingerprint, plus cost counters.

    A Voronoi facet whose polygon did not change since it was found clean is
    not tested again (the surface is fixed, so its crossings did not change).
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
        k = np.concatenate([keys, self.keys])
        p = np.concatenate([prints, self.prints])
        k, first = np.unique(k, return_index=True)  # new entries win
        self.keys, self.prints = k, p[first]


@dataclass
class LoopViolations:
    """Facets with a loop or fold: edge ids and the refinement points."""

    edges: np.ndarray  # (v, 2)
    centres: np.ndarray  # (c, 3)
    radii: np.ndarray  # (c,)


def loop_test(surface, rdt, vertices, tri, centres, status: ComplexStatus, memo=None):
    """Voronoi facets of the sample set meeting the surface in a loop or folded arc.

    Parameters
    ----------
    surface : the implicit surface.
    rdt : the C++ core (``voronoi_facets``, ``delaunay_edges``).
    vertices : (n, 3) samples.
    tri : (F, 3) restricted facets; centres : (F, 3) their surface centres.
    status : :func:`rdmesh.complex.complex_status` of ``tri``.
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
    n = len(vertices)
    edges = rdt.delaunay_edges()
    keys = (edges[:, 0] << 32) | edges[:, 1]
    # Complex edges: 2 crossings (their restricted facets' centres); other
    # non-zero counts are the crossing-count test's.
    ekey = status.edge_key
    elo, ehi = ekey // max(n, 1), ekey % max(n, 1)
    ckeys = (elo << 32) | ehi
    pos = np.searchsorted(ckeys, keys) if len(ckeys) else np.zeros(len(keys), np.int64)
    pos = np.minimum(pos, max(len(ckeys) - 1, 0))
    in_complex = (ckeys[pos] == keys) if len(ckeys) else np.zeros(len(keys), bool)
    count = np.where(in_complex, status.edge_count[pos] if len(ckeys) else 0, 0)
    keep = (count == 0) | (count == 2)
    edges, keys, pos, count = edges[keep], keys[keep], pos[keep], count[keep]
    off, pts, cell, _ = rdt.voronoi_facets(edges)
    sizes = np.diff(off)
    # Fingerprint: the polygon's vertices seen along a fixed direction.
    w = pts @ np.array([0.5772156649, 0.2718281828, 0.3141592653]) + 1.4142135623 * pts[:, 0] ** 2
    prints = np.add.reduceat(w, off[:-1]) if len(pts) else np.zeros(0)
    prints = prints + sizes
    fresh = ~memo.known(keys, prints)
    out = _test(surface, vertices, tri, centres, status, edges, count, pos, off, pts, cell, fresh)
    bad_rows = np.zeros(len(edges), bool)
    bad_rows[out[0]] = True
    clean = fresh & ~bad_rows
    memo.remember(keys[clean], prints[clean])
    memo.tested += int(fresh.sum())
    memo.seconds += time.perf_counter() - t0
    return LoopViolations(edges[out[0]], out[1], out[2])


def _test(surface, vertices, tri, centres, status, edges, count, pos, off, pts, cell, fresh):
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
    k2 = count[rows] == 2
    # Crossings of k = 2 facets: the centres of their two restricted facets.
    a = np.zeros((len(rows), 3))
    b = np.zeros((len(rows), 3))
    if k2.any():
        fe = status.facet_edges.ravel()
        f_of = np.repeat(np.arange(len(tri)), 3)
        order = np.argsort(fe, kind="stable")
        first = np.searchsorted(fe[order], pos[rows[k2]])
        a[k2] = centres[f_of[order[first]]]
        b[k2] = centres[f_of[order[first + 1]]]
    # k = 0 facets: only those near the surface to first order.
    k0 = ~k2
    near = np.zeros(len(rows), bool)
    near[k2] = True
    best = np.zeros(len(rows), np.int64)  # polygon vertex nearest the surface
    if k0.any():
        sel = k0[owner]
        ucell, inv = np.unique(cell[idx[sel]], return_inverse=True)
        first_pt = np.zeros(len(ucell), np.int64)
        first_pt[inv] = np.flatnonzero(sel)
        up = poly[first_pt]
        fv = surface(up)[inv]
        gv = surface.grad(up)[inv]
        o = owner[sel]
        g_in = gv - np.einsum("ij,ij->i", gv, nrm[o])[:, None] * nrm[o]
        dist = np.abs(fv) / np.maximum(np.linalg.norm(g_in, axis=1), 1e-300)
        near |= np.bincount(o, weights=dist < diam[o], minlength=len(rows)) > 0
        # The nearest vertex of each polygon (last in lexsort order).
        ordv = np.lexsort((-dist, o))
        last = np.r_[o[ordv][1:] != o[ordv][:-1], True]
        best[o[ordv][last]] = np.flatnonzero(sel)[ordv][last]
    # Plane frames.
    e1 = np.where(k2[:, None], b - a, 0.0)
    e1 -= np.einsum("ij,ij->i", e1, nrm)[:, None] * nrm
    l1 = np.linalg.norm(e1, axis=1)
    helper = np.where(np.abs(nrm[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    alt = np.cross(nrm, helper)
    e1 = np.where((l1 > 1e-12 * diam)[:, None], e1, alt)
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(nrm, e1)
    # Folded arcs seen at the ends: the arc's direction along the chord has
    # opposite signs at a and b (so <grad f, e2> vanishes on the arc).
    fold = np.zeros(len(rows), bool)
    if k2.any():
        g = surface.grad(np.concatenate([a[k2], b[k2]])).reshape(2, -1, 3)
        e2k = e2[k2]
        ga, gb = np.einsum("nj,nj->n", g[0], e2k), np.einsum("nj,nj->n", g[1], e2k)
        fold[k2] = ga * gb < 0
        ta = np.abs(ga) / np.maximum(np.linalg.norm(g[0], axis=1), 1e-300)
        tb = np.abs(gb) / np.maximum(np.linalg.norm(g[1], axis=1), 1e-300)
        # |<grad, e2>| / |grad| is the cosine between the arc and the chord
        # (for a facet plane close to the surface normal).
        straight = np.zeros(len(rows), bool)
        straight[k2] = np.minimum(ta, tb) >= MONOTONE_COS
    else:
        straight = np.zeros(len(rows), bool)
    # Seeds: chord midpoint (k = 2), centroid (k = 2 unless straight, and
    # k = 0 near), nearest vertex (k = 0 near).
    s_rows, s_pts = [], []
    m2 = np.flatnonzero(k2 & ~fold)
    s_rows.append(m2)
    s_pts.append(0.5 * (a[m2] + b[m2]))
    mc = np.flatnonzero((k2 & ~fold & ~straight) | (k0 & near))
    s_rows.append(mc)
    s_pts.append(centroid[mc])
    mv = np.flatnonzero(k0 & near)
    s_rows.append(mv)
    s_pts.append(poly[best[mv]])
    srow = np.concatenate(s_rows)
    x = np.concatenate(s_pts)
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
    for _ in range(ITERATIONS):
        if len(x) == 0:
            break
        u, v, n_ = e1[row], e2[row], nrm[row]
        h = 1e-4 * diam[row]
        f = surface(x)
        g3 = surface.grad(np.concatenate([x, x + h[:, None] * u, x + h[:, None] * v]))
        g3 = g3.reshape(3, len(x), 3)
        g = g3[0]
        g1 = np.einsum("ij,ij->i", g, u)
        g2 = np.einsum("ij,ij->i", g, v)
        gn = np.maximum(np.linalg.norm(g - np.einsum("ij,ij->i", g, n_)[:, None] * n_, axis=1),
                        1e-300)
        ok = (np.abs(f) <= 1e-9 * diam[row] * gn) & (np.abs(g2) <= 1e-7 * gn)
        if ok.any():
            done_r.append(row[ok])
            done_x.append(x[ok])
        # Jacobian of (f, g2) in the plane coordinates (s along e1, t along e2).
        j21 = np.einsum("ij,ij->i", g3[1] - g, v) / h
        j22 = np.einsum("ij,ij->i", g3[2] - g, v) / h
        j11, j12 = g1, g2
        det = j11 * j22 - j12 * j21
        scale = np.abs(j11 * j22) + np.abs(j12 * j21)
        solvable = np.abs(det) > 1e-12 * np.maximum(scale, 1e-300)
        det = np.where(solvable, det, 1.0)
        ds = -(j22 * f - j12 * g2) / det
        dt = -(-j21 * f + j11 * g2) / det
        step = ds[:, None] * u + dt[:, None] * v
        length = np.linalg.norm(step, axis=1)
        # A full step beyond the polygon's size: no solution near this seed.
        solvable &= length <= STRAY * diam[row]
        cap = 0.25 * diam[row]
        step *= np.minimum(1.0, cap / np.maximum(length, 1e-300))[:, None]
        x = x + step
        # Stray seeds leave: far outside their polygon, or no step.
        stay = (
            ~ok
            & solvable
            & (np.linalg.norm(x - centroid[row], axis=1) <= 0.75 * diam[row])
        )
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
    dist = side / np.maximum(edge_len, 1e-300)
    eps = 1e-9 * diam[row][which]
    real = edge_len > eps
    not_pos = np.bincount(which, weights=(dist <= eps) & real, minlength=len(x))
    not_neg = np.bincount(which, weights=(dist >= -eps) & real, minlength=len(x))
    return (not_pos == 0) | (not_neg == 0)
