"""The curve where the surface leaves the bounding ball: found, traced and sampled.

For ``topology="manifold-with-boundary"`` the surface may cross the bounding
sphere S; the mesh is the part inside, and its boundary should follow the
curve C = {f = 0} on S. ``f`` is evaluated on a fine point set on S, a
latitude-longitude grid triangulated directly (:func:`sphere_grid`); every
grid edge whose ends differ in sign gives a crossing (one vectorised root
search along the great-circle arc), and each triangle with crossings joins
its two crossings (marching triangles), which traces the loops of C. Each
loop is resampled at a spacing
of at most the size bound (tighter where the curve bends, so that a chord
stays within the distance bound), and every point is then projected onto C by
Newton steps along the sphere. These points are inserted first, as fixed
samples. Sampled: a loop of C smaller than the point set's spacing is missed.

When the surface has a clip box (``ImplicitSurface.clip_box``, inside the
ball) the same is done on the box's surface instead: a grid on each face,
the faces sharing their edge points (:func:`box_grid`), so the loops run on
across the faces. C has a corner where it crosses a box edge; that crossing
is found by the root search along the grid edges lying on the box edges,
kept as a sample (resampling runs from corner to corner) and never moved.
Newton steps then stay in each point's face.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from scipy.optimize import elementwise
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from .._newton import damped_step
from .._vectors import row_norms
from ..surfaces.oracle import ImplicitSurface
from .domain import clip_box, on_clip_surface

log = logging.getLogger("rdmesh")

#: Points of the sphere grid: at most about this many, at least about MIN_POINTS.
MAX_POINTS, MIN_POINTS = 400_000, 4_000
#: Newton steps projecting curve points onto f = 0 on the sphere.
PROJECT_ITERATIONS = 30
#: Curve points per size bound when no distance bound tightens it.
PER_BOUND = 1.0
#: Root search along a grid edge: bracket width, as a fraction of the edge.
EDGE_ROOT_TOL = 1e-14
#: A curve sample is on the surface when |f| / |grad f| is below this, times R.
CURVE_TOL = 1e-10


@dataclass
class BoundaryCurve:
    """Samples of the curve where the surface meets the bounding sphere.

    Attributes
    ----------
    points : (m, 3) on the sphere (to rounding) and on the surface (to the
        projection's tolerance), loop after loop, in order along each loop.
    loop : (m,) int64 the loop of each point.
    lengths : (L,) the length of each traced loop (of its fine polyline).
    spacing : mean spacing of the sphere grid that found the curve.
    size : the largest spacing of the samples along the curve.
    dense : (q, 3) the traced curve: the crossings of the sphere grid's
        edges, on the curve, consecutive ones at most ``gap`` apart.
    gap : the longest edge of the sphere grid (times R): a bound on
        the distance between consecutive traced points.
    domain : "sphere" or "box": the surface the curve was traced on.
    corners : (c, 3) the samples where the curve crosses a box edge (found
        by root finding along the edge; also in ``points``).
    dense_loop : (q,) int64 the loop of each point of ``dense`` (each loop's
        points are contiguous, in order along it).
    """

    points: np.ndarray
    loop: np.ndarray
    lengths: np.ndarray
    spacing: float
    size: float
    dense: np.ndarray
    gap: float = 0.0
    domain: str = "sphere"
    corners: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    dense_loop: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))

    @property
    def n_loops(self) -> int:
        return len(self.lengths)

    @cached_property
    def _polyline(self) -> _Polyline:
        return _Polyline.of(self.dense, self.dense_loop, self.n_loops)

    def locate(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The loop of each point ``(k, 3)`` near the curve and its arc position
        along it (on the traced polyline, from the loop's first point): the
        nearest point of the polyline. Returns ``(loop (k,), arc (k,))``."""
        return self._polyline.locate(x)

    def point_at(self, loop: np.ndarray, arc: np.ndarray) -> np.ndarray:
        """The traced polyline's point at arc position ``arc`` of loop ``loop``, ``(k, 3)``."""
        return self._polyline.point_at(loop, arc)

    @property
    def loop_lengths(self) -> np.ndarray:
        """(L,) the length of each loop's traced polyline (closed)."""
        return self._polyline.total


@dataclass
class _Polyline:
    """The traced curve as closed polylines, one per loop, with arc positions."""

    dense: np.ndarray  # (q, 3)
    loop: np.ndarray  # (q,)
    seg: np.ndarray  # (q, 3) from each point to the next along its loop
    ell: np.ndarray  # (q,) the segments' lengths
    before: np.ndarray  # (q,) length of the whole polyline (all loops) before each point
    offset: np.ndarray  # (L,) ``before`` at each loop's first point
    total: np.ndarray  # (L,) each loop's length
    starts: np.ndarray  # (L,) each loop's first point
    ends: np.ndarray  # (L,) one past each loop's last point
    tree: cKDTree

    @classmethod
    def of(cls, dense: np.ndarray, loop: np.ndarray, n_loops: int) -> _Polyline:
        counts = np.bincount(loop, minlength=n_loops)
        ends = np.cumsum(counts)
        starts = ends - counts
        nxt = np.arange(len(dense)) + 1
        has = counts > 0
        nxt[ends[has] - 1] = starts[has]
        seg = dense[nxt] - dense
        ell = row_norms(seg)
        before = np.cumsum(ell) - ell
        offset = np.where(has, before[np.minimum(starts, len(dense) - 1)], 0.0)
        total = np.bincount(loop, weights=ell, minlength=n_loops)
        return cls(dense, loop, seg, ell, before, offset, total, starts, ends, cKDTree(dense))

    def locate(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        _, j = self.tree.query(x)
        loop = self.loop[j]
        # The nearer of the two polyline segments at the nearest point.
        prv = np.where(j == self.starts[loop], self.ends[loop] - 1, j - 1)
        best_d, best_arc = np.full(len(x), np.inf), np.zeros(len(x))
        for s in (prv, j):
            ell2 = np.maximum(self.ell[s] ** 2, 1e-300)
            w = np.clip(np.einsum("ij,ij->i", x - self.dense[s], self.seg[s]) / ell2, 0.0, 1.0)
            d = row_norms(self.dense[s] + w[:, None] * self.seg[s] - x)
            arc = self.before[s] - self.offset[loop] + w * self.ell[s]
            better = d < best_d
            best_d[better], best_arc[better] = d[better], arc[better]
        return loop, np.mod(best_arc, np.maximum(self.total[loop], 1e-300))

    def point_at(self, loop: np.ndarray, arc: np.ndarray) -> np.ndarray:
        key = self.offset[loop] + np.mod(arc, np.maximum(self.total[loop], 1e-300))
        j = np.searchsorted(self.before, key, side="right") - 1
        j = np.clip(j, self.starts[loop], self.ends[loop] - 1)
        w = np.clip((key - self.before[j]) / np.maximum(self.ell[j], 1e-300), 0.0, 1.0)
        return self.dense[j] + w[:, None] * self.seg[j]


def boundary_curve(
    surface: ImplicitSurface,
    size: float,
    distance: float | None = None,
    resolution: int = 64,
    sizing: Callable[[np.ndarray], np.ndarray] | None = None,
) -> BoundaryCurve:
    """Find and sample the curve ``f = 0`` on the clipping surface: the
    bounding sphere, or the surface's clip box.

    Parameters
    ----------
    surface : ImplicitSurface
    size : float
        Largest spacing of the samples along the curve (the size bound).
    distance : float, optional
        Largest distance between the curve and a chord between consecutive
        samples, estimated from the traced curve's turning.
    resolution : int
        The grid scan's resolution: the sphere grid is at least as fine.
    sizing : callable, optional
        A sizing field, ``(N, 3)`` points to ``N`` radii: the samples are at
        most its value apart where it is below ``size``.

    Returns
    -------
    BoundaryCurve
        Empty when ``f`` does not change sign on the sampled surface.
    """
    c0, R = surface.centre, surface.radius
    box = clip_box(surface)
    # Spacing: a quarter of the size bound, and finer than the grid scan.
    h = min(0.25 * size, 2.0 * R / resolution)
    if box is None:
        # A grid of about 2 pi^2 / h^2 points, within the point budget.
        lo, hi = np.sqrt(2.0 * np.pi**2 / MAX_POINTS), np.sqrt(2.0 * np.pi**2 / MIN_POINTS)
        u, ends, tri_edges = sphere_grid(float(np.clip(h / R, lo, hi)))
        x = c0 + R * u
        h = np.sqrt(4.0 * np.pi / len(u)) * R
        on_edge = np.zeros(len(ends), bool)
        domain = "sphere"
    else:
        e = box[1] - box[0]
        area = 2.0 * float(e[0] * e[1] + e[1] * e[2] + e[0] * e[2])
        h = float(np.clip(h, np.sqrt(area / MAX_POINTS), np.sqrt(area / MIN_POINTS)))
        x, ends, tri_edges, on_edge = box_grid(box, h)
        domain = "box"
    n = len(x)
    inside = surface(x) < 0
    a, b = ends[:, 0], ends[:, 1]
    cut = inside[a] != inside[b]
    gap = float(row_norms(x[a] - x[b]).max())
    empty = BoundaryCurve(
        np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros(0), h, size, np.zeros((0, 3)),
        gap, domain,
    )  # fmt: skip
    if not cut.any():
        return empty
    cut_id = np.full(len(ends), -1)
    cut_id[cut] = np.arange(int(cut.sum()))
    if box is None:
        crossing = _arc_roots(surface, u[a[cut]], u[b[cut]])
    else:
        crossing = _edge_roots(surface, x[a[cut]], x[b[cut]], None)
    corner = on_edge[cut]
    # Marching triangles: a triangle with a sign change has exactly two cut edges.
    ids = cut_id[tri_edges]  # (T, 3) cut index of each triangle edge
    has = ids >= 0
    two = has.sum(axis=1) == 2
    pairs = np.sort(ids[two], axis=1)[:, 1:]  # the two non-negative ids
    m = len(crossing)
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(m, m))
    n_loops, label = connected_components(g, directed=False)
    order, loop = _loop_order(pairs, label, n_loops, m)
    order = _start_at_corners(order, loop, corner)
    pts, fixed = crossing[order], corner[order]
    local = np.full(len(pts), size) if sizing is None else np.minimum(size, sizing(pts))
    points, which, lengths, kept = _resample(pts, loop, n_loops, local, distance, fixed)
    moving = ~kept
    points[moving] = project_onto_curve(surface, points[moving])
    # A projection that did not converge is not on the surface: dropped.
    g = row_norms(surface.grad(points))
    on = np.abs(surface(points)) <= CURVE_TOL * R * np.maximum(g, 1e-300)
    if not on.all():
        log.warning(
            "boundary curve: %d of %d samples did not converge onto the curve and were "
            "dropped (the surface may be tangent to the %s there)",
            int((~on).sum()),
            len(on),
            domain,
        )
        points, which, kept = points[on], which[on], kept[on]
    log.info(
        "boundary curve: %d loops on the %s (%d grid points), %d samples, %d at box edges",
        n_loops,
        domain,
        n,
        len(points),
        int(kept.sum()),
    )
    return BoundaryCurve(
        points, which, lengths, h, size, pts, gap, domain, points[kept], loop.astype(np.int64)
    )


def box_grid(box: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A triangulated point grid on the surface of an axis-aligned box, edges about ``h``.

    Each face is a grid of the box's lattice points, its quads split along a
    diagonal; faces share the points of their common edges, so the grid is
    one closed surface. Inner lattice lines are shifted off the uniform
    positions by an irrational fraction of a cell, so that planes at round
    coordinates do not run through rows of grid points.

    Returns
    -------
    x : (n, 3) the points.
    ends : (E, 2) the two points of each edge.
    tri_edges : (T, 3) the three edges of each triangle.
    on_edge : (E,) bool: the grid edge lies on an edge of the box.
    """
    lo, hi = box
    axes = []
    for k in range(3):
        cells = max(1, int(np.ceil((hi[k] - lo[k]) / h)))
        t = (np.arange(cells) + _SHIFT) / cells
        # The ends are the bounds themselves: lo + (hi - lo) * 1 can round
        # off hi, and then no grid edge would be found on that box edge.
        axes.append(np.r_[lo[k], lo[k] + (hi[k] - lo[k]) * t, hi[k]])
    size = np.array([len(a) for a in axes])
    keys, tris = [], []
    for k in range(3):
        b, c = [j for j in range(3) if j != k]
        nb, nc = size[b], size[c]
        i, j = np.meshgrid(np.arange(nb), np.arange(nc), indexing="ij")
        for side in (0, size[k] - 1):
            idx = np.zeros((nb, nc, 3), np.int64)
            idx[..., k], idx[..., b], idx[..., c] = side, i, j
            key = (idx[..., 0] * size[1] + idx[..., 1]) * size[2] + idx[..., 2]
            p00, p10 = key[:-1, :-1].ravel(), key[1:, :-1].ravel()
            p11, p01 = key[1:, 1:].ravel(), key[:-1, 1:].ravel()
            keys.append(key.ravel())
            tris += [np.column_stack([p00, p10, p11]), np.column_stack([p00, p11, p01])]
    uniq = np.unique(np.concatenate(keys))
    tri = np.searchsorted(uniq, np.concatenate(tris))
    ii, r = np.divmod(uniq, size[1] * size[2])
    jj, kk = np.divmod(r, size[2])
    x = np.column_stack([axes[0][ii], axes[1][jj], axes[2][kk]])
    # Edges: each triangle's three sides, shared sides once.
    sides = np.sort(np.stack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]], axis=1), axis=2)
    # By integer key: np.unique over rows sorts a structured view, 4x slower.
    pair = sides.reshape(-1, 2)
    key, inverse = np.unique(pair[:, 0] * len(x) + pair[:, 1], return_inverse=True)
    ends = np.column_stack(np.divmod(key, len(x)))
    tri_edges = inverse.reshape(-1, 3)
    # An edge on a box edge has both ends with two coordinates at the bounds.
    at = (x == lo) | (x == hi)
    two = at.sum(axis=1) >= 2
    same = (at[ends[:, 0]] & at[ends[:, 1]]).sum(axis=1) >= 2
    on_edge = two[ends[:, 0]] & two[ends[:, 1]] & same
    return x, ends, tri_edges, on_edge


#: Inner lattice lines of the box grid sit at (i + _SHIFT) / cells.
_SHIFT = (3.0 - np.sqrt(5.0)) / 2.0  # 0.382, irrational


def _unit_to_sphere(c0: np.ndarray, R: float) -> Callable[[np.ndarray], np.ndarray]:
    """Nonzero vectors ``(..., 3)`` to the points of the sphere in their directions."""

    def onto(y: np.ndarray) -> np.ndarray:
        return c0 + R * (y / np.linalg.norm(y, axis=-1, keepdims=True))

    return onto


def _start_at_corners(order: np.ndarray, loop: np.ndarray, corner: np.ndarray) -> np.ndarray:
    """Each loop's order turned to start at one of its corners, if it has any
    (so resampling can run from corner to corner)."""
    if not corner.any():
        return order
    order = order.copy()
    ends = np.cumsum(np.bincount(loop))
    for s, e in zip(ends - np.bincount(loop), ends, strict=True):
        at = np.flatnonzero(corner[order[s:e]])
        if len(at):
            order[s:e] = np.roll(order[s:e], -int(at[0]))
    return order


#: A fixed rotation with no special axis (rotation vector (0.31, 0.73, 0.19) rad).
_TILT = Rotation.from_rotvec([0.31, 0.73, 0.19]).as_matrix()


def sphere_grid(h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A triangulated latitude-longitude grid of the unit sphere, edges at most ``h`` (about).

    Rings of equal colatitude step ``pi / (m + 1) <= h`` hold ``L`` points each,
    ``2 pi / L <= h`` apart along the equator; each quad between two rings is
    split along a diagonal, and each pole joins its nearest ring in a fan.
    Built directly, with no convex hull (qhull took 13 s and about 200 MB for
    the 360k points of a fine boundary search).

    Returns
    -------
    u : (n, 3) the unit points (north pole first, south pole last).
    ends : (E, 2) the two points of each edge.
    tri_edges : (T, 3) the three edges of each triangle.
    """
    m = max(2, int(np.ceil(np.pi / h)))
    L = max(3, int(np.ceil(2.0 * np.pi / h)))
    theta = np.pi * np.arange(1, m + 1) / (m + 1)
    phi = 2.0 * np.pi * np.arange(L) / L
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    ring = np.stack([st * np.cos(phi), st * np.sin(phi), np.broadcast_to(ct, (m, L))], axis=-1)
    u = np.concatenate([[[0.0, 0.0, 1.0]], ring.reshape(-1, 3), [[0.0, 0.0, -1.0]]])
    # Turned to a generic position: axis-aligned surfaces (a cylinder along z)
    # would otherwise meet the sphere exactly along a ring of grid points.
    u = u @ _TILT.T
    north, south = 0, 1 + m * L
    i, j = np.divmod(np.arange(m * L), L)
    v = 1 + i * L + j  # point (i, j)
    right = 1 + i * L + (j + 1) % L  # point (i, j + 1)
    # Edge ids: ring edges (i, j)-(i, j+1), then meridians (i, j)-(i+1, j) and
    # diagonals (i, j)-(i+1, j+1) for i < m - 1, then the two pole fans.
    band = i < m - 1
    vb, rb = v[band], right[band]
    n_ring, n_band = m * L, (m - 1) * L
    ends = np.concatenate(
        [
            np.column_stack([v, right]),
            np.column_stack([vb, vb + L]),
            np.column_stack([vb, rb + L]),
            np.column_stack([np.full(L, north), 1 + np.arange(L)]),
            np.column_stack([np.full(L, south), 1 + (m - 1) * L + np.arange(L)]),
        ]
    )
    ring_e = np.arange(n_ring)
    mer_e = n_ring + np.arange(n_band)
    diag_e = n_ring + n_band + np.arange(n_band)
    nf = 2 * n_band + n_ring + np.arange(L)
    sf = nf + L
    jb = np.arange(n_band) % L
    jn = (jb + 1) % L  # the meridian at j + 1 of the same band
    mer_next = mer_e - jb + jn
    next_j = (j[:L] + 1) % L
    tri_edges = np.concatenate(
        [
            # (i, j), (i+1, j), (i+1, j+1): meridian j, ring i+1 edge j, diagonal j.
            np.column_stack([mer_e, ring_e[L:], diag_e]),
            # (i, j), (i+1, j+1), (i, j+1): diagonal j, meridian j+1, ring i edge j.
            np.column_stack([diag_e, mer_next, ring_e[:n_band]]),
            # The caps: pole, (0, j), (0, j+1) and pole, (m-1, j), (m-1, j+1).
            np.column_stack([nf, ring_e[:L], nf - j[:L] + next_j]),
            np.column_stack([sf, ring_e[n_ring - L :], sf - j[:L] + next_j]),
        ]
    )
    return u, ends, tri_edges


def _arc_roots(surface: ImplicitSurface, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The crossing of ``f`` on the arc from ``c0 + R p`` to ``c0 + R q`` (unit p, q)."""
    return _edge_roots(surface, p, q, _unit_to_sphere(surface.centre, surface.radius))


def _edge_roots(
    surface: ImplicitSurface,
    p: np.ndarray,
    q: np.ndarray,
    onto: Callable[[np.ndarray], np.ndarray] | None,
) -> np.ndarray:
    """The crossing of ``f`` on each grid edge from ``p`` to ``q``: a straight
    segment, or its image under ``onto`` (the great-circle arc on the sphere)."""

    def point(t, px, py, pz, qx, qy, qz):
        x = np.stack([px + t * (qx - px), py + t * (qy - py), pz + t * (qz - pz)], axis=-1)
        return x if onto is None else onto(x)

    def g(t, *args):
        return surface(point(t, *args).reshape(-1, 3)).reshape(np.shape(t))

    args = (p[:, 0], p[:, 1], p[:, 2], q[:, 0], q[:, 1], q[:, 2])
    # Bracket widths below 1e-14 of the edge: some functions (a sampled
    # volume) never meet a relative tolerance of 0, and the search would run to
    # scipy's iteration cap for a few edges (2,048 calls of f).
    res = elementwise.find_root(
        g, (np.zeros(len(p)), np.ones(len(p))), args=args,
        tolerances={"xrtol": 0.0, "xatol": EDGE_ROOT_TOL}, maxiter=200,
    )  # fmt: skip
    t = res.x
    # Status -2 (the iteration cap at this tight tolerance) still leaves a
    # converged bracket; a NaN comes where f rounds to 0 at an end (the curve
    # runs through a grid point): that end is the crossing.
    failed = ~np.isfinite(t)
    if failed.any():
        sub = tuple(a[failed] for a in args)
        fa = np.abs(surface(point(np.zeros(int(failed.sum())), *sub)))
        fb = np.abs(surface(point(np.ones(int(failed.sum())), *sub)))
        t = t.copy()
        t[failed] = np.where(fa <= fb, 0.0, 1.0)
        log.debug("boundary curve: %d edge root searches ended at a grid point", int(failed.sum()))
    return point(t, *args)


def _loop_order(pairs: np.ndarray, label: np.ndarray, n_loops: int, m: int):
    """The crossings in order along each loop: (order, loop of each)."""
    # Each crossing lies on one cut edge, shared by two triangles: it has
    # exactly two neighbours. Neighbour lists by one sort; all loops are
    # walked at once, one step per crossing of the longest loop.
    src = np.concatenate([pairs[:, 0], pairs[:, 1]])
    dst = np.concatenate([pairs[:, 1], pairs[:, 0]])
    o = np.lexsort((dst, src))
    src, dst = src[o], dst[o]
    first = np.searchsorted(src, np.arange(m))
    deg = np.bincount(src, minlength=m)
    nb = np.full((m, 2), -1)
    nb[deg > 0, 0] = dst[first[deg > 0]]
    nb[deg > 1, 1] = dst[first[deg > 1] + 1]
    # The smallest crossing index of each loop starts it (deterministic).
    start = np.full(n_loops, m)
    np.minimum.at(start, label, np.arange(m))
    size = np.bincount(label, minlength=n_loops)
    prev = np.full(n_loops, -1)
    cur = start.copy()
    steps = np.zeros((size.max(), n_loops), np.int64)
    for k in range(size.max()):
        steps[k] = cur
        nxt = np.where(nb[cur, 0] != prev, nb[cur, 0], nb[cur, 1])
        nxt = np.where(nxt < 0, cur, nxt)
        prev, cur = cur, nxt
    valid = np.arange(size.max())[:, None] < size[None, :]
    order = steps.T[valid.T]
    loop = np.repeat(np.arange(n_loops), size)
    return order, loop


def _resample(pts, loop, n_loops, size, distance, fixed=None):
    """Points along each closed polyline, at most ``size`` (per point) apart
    (tighter where the turning would put a chord farther than ``distance``
    from the curve).

    ``fixed`` marks polyline points kept as samples (corners of the curve):
    each loop is then resampled from one to the next; a loop with fixed
    points must start at one. Returns ``(points, loop of each, loop lengths,
    which points are fixed ones)``.
    """
    fixed = np.zeros(len(pts), bool) if fixed is None else fixed
    nxt = np.arange(len(pts)) + 1
    ends = np.cumsum(np.bincount(loop, minlength=n_loops))
    starts = ends - np.bincount(loop, minlength=n_loops)
    nxt[ends - 1] = starts
    seg = pts[nxt] - pts
    ell = row_norms(seg)
    lengths = np.bincount(loop, weights=ell, minlength=n_loops)
    spacing = np.asarray(size, dtype=float)
    if distance is not None:
        # Curvature at each polyline vertex: turning angle over the mean
        # length of its two segments; a chord of length L bulges L^2 k / 8.
        # A corner's turn is not curvature: its arcs end there anyway.
        prv = np.arange(len(pts)) - 1
        prv[starts] = ends - 1
        t_in, t_out = seg[prv], seg
        cos = np.einsum("ij,ij->i", t_in, t_out) / np.maximum(ell[prv] * ell, 1e-300)
        cos[fixed] = 1.0
        kappa = np.arccos(np.clip(cos, -1.0, 1.0)) / np.maximum(0.5 * (ell[prv] + ell), 1e-300)
        with np.errstate(divide="ignore"):
            spacing = np.minimum(size, np.sqrt(8.0 * distance / np.maximum(kappa, 1e-300)))
    # Arcs: each loop from one fixed point to the next (a whole loop without
    # any). Samples per segment: its length over the local spacing,
    # accumulated; each arc gets an integer number of samples, its first
    # point being its start (at least 3 per loop).
    density = ell / np.minimum(spacing, spacing[nxt])
    cum = np.cumsum(density)
    before = np.r_[0.0, cum]
    first = np.zeros(len(pts), bool)
    first[starts] = True
    first |= fixed
    a_start = np.flatnonzero(first)
    a_end = np.r_[a_start[1:], len(pts)]
    a_end = np.minimum(a_end, ends[loop[a_start]])
    arc_loop = loop[a_start]
    base = before[a_start]
    total = before[a_end] - base
    whole = np.bincount(arc_loop, minlength=n_loops)[arc_loop] == 1
    count = np.maximum(np.ceil(total * PER_BOUND).astype(np.int64), np.where(whole, 3, 1))
    arc = np.repeat(np.arange(len(a_start)), count)
    k = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    target = base[arc] + total[arc] * k / count[arc]
    # Locate each target in its arc's cumulative density.
    j = np.searchsorted(cum, target, side="right")
    j = np.clip(j, a_start[arc], a_end[arc] - 1)
    w = (target - before[j]) / np.maximum(density[j], 1e-300)
    points = pts[j] + np.clip(w, 0.0, 1.0)[:, None] * seg[j]
    kept = (k == 0) & fixed[a_start[arc]]
    points[kept] = pts[a_start[arc[kept]]]
    return points, arc_loop[arc], lengths, kept


#: A refinement point moved onto the curve away from a chord's middle (see
#: :func:`guard_boundary`) is kept when it lies farther than this, times its
#: ball's radius, from every sample.
SNAP_KEEP = 0.25
#: Seeds closer than this to the sphere, times the curve's spacing, are dropped.
SEED_BAND = 0.6
#: The curve's 1-D refinement splits a chord between consecutive boundary
#: vertices only when both halves are at least this, times the local size
#: bound, long (along the traced curve): boundary edges stay at least this
#: long, up to the chord-to-arc ratio, whatever refines them.
BOUNDARY_MIN = 0.25
#: Points that are not optional may split shorter chords, down to halves of
#: this, times the local size bound.
SHORT_MIN = 0.125
#: A chord's middle is not inserted when a sample lies closer to it than
#: this, times half the chord.
SPLIT_KEEP = 0.5
#: Triangles with an edge on the boundary are held to the angle bound while
#: their surface Delaunay ball is larger than this, times the local size
#: bound (the floor that makes the refinement at the boundary terminate).
BOUNDARY_ANGLE_FLOOR = 0.25


@dataclass
class Guarded:
    """What :func:`guard_boundary` did with k refinement points.

    Attributes
    ----------
    points : (k, 3) the points, moved where ``snapped``.
    radii : (k,) their balls' radii: half the chord for a chord's middle.
    snapped : (k,) bool: moved onto the curve.
    keep : (k,) bool: False where the point can be neither moved nor inserted.
    dropped : (k,) bool: not kept, but optional (``soft``): not a failure.
    """

    points: np.ndarray
    radii: np.ndarray
    snapped: np.ndarray
    keep: np.ndarray
    dropped: np.ndarray


def guard_boundary(
    surface: ImplicitSurface,
    curve: BoundaryCurve,
    centres: np.ndarray,
    radii: np.ndarray,
    tree: cKDTree,
    samples: np.ndarray,
    sizing: Callable[[np.ndarray], np.ndarray],
    soft: np.ndarray | None = None,
) -> Guarded:
    """Keep interior refinement points off the boundary curve; refine the
    curve in 1-D instead.

    A sample becomes a boundary vertex when it is the nearest sample of some
    point of the curve. Every traced curve point ``c`` (the fine polyline)
    has its nearest sample at distance ``d(c)``; a refinement point ``p``
    with ``|c - p| > d(c) + gap`` for every ``c`` (``gap`` bounds the
    distance between consecutive traced points) leaves the boundary as it
    is and is inserted unchanged. Any other ``p`` encroaches on the curve:
    it is projected onto the curve, and the chord between the two
    consecutive boundary vertices around the projection (along the traced
    curve) is split at its middle instead, as Ruppert's refinement splits an
    encroached segment, when both halves are at least ``BOUNDARY_MIN`` times
    the local size bound long and no sample lies within ``SPLIT_KEEP`` half
    chords of the middle. Boundary vertices are thus never closer along the
    curve than that (the first samples are about the size bound apart).

    When the chord is not split by that rule, a point that is not ``soft``
    is moved to the chord's middle all the same (the chord's point farthest
    from its ends) if its projection lands within ``2 size`` of ``p``, the
    halves are at least ``SHORT_MIN`` times the size bound long and the
    middle lies farther than ``SNAP_KEEP`` times its ball's radius from
    every sample; otherwise it is inserted unchanged if only the margin ``gap`` caught it
    (``|c - p| > d(c)`` at every traced point), dropped if ``soft`` (a
    triangle bad only by the angle bound at the boundary) and refused
    otherwise.

    Parameters
    ----------
    surface : ImplicitSurface
    curve : BoundaryCurve
    centres : (k, 3) refinement points inside the ball.
    radii : (k,) their balls' radii.
    tree : KD-tree of the current samples.
    samples : (n, 3) the current samples.
    sizing : the local size bound, ``(N, 3)`` points to ``N`` lengths.
    soft : (k,) bool, optional: points that may be dropped.

    Returns
    -------
    Guarded
    """
    k = len(centres)
    soft = np.zeros(k, bool) if soft is None else np.asarray(soft, bool)
    out = Guarded(centres.copy(), radii.copy(), np.zeros(k, bool), np.ones(k, bool),
                  np.zeros(k, bool))  # fmt: skip
    if k == 0 or len(curve.dense) == 0:
        return out
    d_c, _ = tree.query(curve.dense)
    reach = d_c + curve.gap
    pairs = cKDTree(centres).sparse_distance_matrix(
        cKDTree(curve.dense), float(reach.max()), output_type="coo_matrix"
    )
    rows = np.unique(pairs.row[pairs.data <= reach[pairs.col]])
    if len(rows) == 0:
        return out
    # Nearer to a traced point than its nearest sample, without the margin.
    closer = np.zeros(k, bool)
    closer[pairs.row[pairs.data <= d_c[pairs.col]]] = True
    moved = project_onto_curve(surface, centres[rows])
    near = row_norms(moved - centres[rows]) < 2.0 * curve.size
    middle, half, ok, middle_ok = _split_chords(surface, curve, samples, tree, moved, sizing)
    split = near & ok
    out.points[rows[split]] = middle[split]
    out.radii[rows[split]] = half[split]
    # A chord too short to split by the rule: its middle (the point of the
    # chord farthest from its ends) all the same, for a point that is not
    # optional, when it stays away from the samples.
    d, _ = tree.query(middle)
    onto = ~split & near & middle_ok & (d > SNAP_KEEP * radii[rows]) & ~soft[rows]
    onto &= half >= SHORT_MIN * sizing(middle)
    out.points[rows[onto]] = middle[onto]
    out.radii[rows[onto]] = half[onto]
    out.snapped[rows[split | onto]] = True
    # A point that cannot be moved stays where it is when only the margin
    # caught it; otherwise it is dropped (soft) or refused.
    stuck = rows[~split & ~onto & closer[rows]]
    out.keep[stuck] = False
    out.dropped[stuck] = soft[stuck]
    log.debug(
        "boundary guard: %d of %d points at the curve: %d chords split, %d short ones, "
        "%d dropped, %d refused",
        len(rows), k, int(split.sum()), int(onto.sum()), int(out.dropped.sum()),
        len(stuck) - int(out.dropped.sum()),
    )  # fmt: skip
    return out


def _split_chords(
    surface: ImplicitSurface,
    curve: BoundaryCurve,
    samples: np.ndarray,
    tree: cKDTree,
    q: np.ndarray,
    sizing: Callable[[np.ndarray], np.ndarray],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The middle of the chord around each curve point ``q`` ``(k, 3)``.

    The boundary vertices (the samples on the clipping surface) are ordered
    along each loop by arc position on the traced curve; the chord around
    ``q`` joins the last one before it and the first one after it (cyclically).
    Its middle is the point of the traced curve halfway along the arc,
    projected onto the curve. Returns ``(middle (k, 3), half the arc (k,),
    ok (k,), placed (k,))``: ``placed`` is False where the loop has no
    boundary vertex or the projection did not converge, ``ok`` also where
    the chord is too short to split (``BOUNDARY_MIN``) or a sample is too
    close to its middle (``SPLIT_KEEP``).
    """
    k = len(q)
    middle, half, ok = np.zeros((k, 3)), np.zeros(k), np.zeros(k, bool)
    on = on_clip_surface(surface, samples)
    if not on.any():
        return middle, half, ok, ok.copy()
    lb, tb = curve.locate(samples[on])
    lq, tq = curve.locate(q)
    total, offset = curve.loop_lengths, curve._polyline.offset
    key = offset[lb] + tb
    o = np.argsort(key, kind="stable")
    key, lb, tb = key[o], lb[o], tb[o]
    loops = np.arange(curve.n_loops)
    first = np.searchsorted(lb, loops, side="left")[lq]
    end = np.searchsorted(lb, loops, side="right")[lq]
    has = end > first
    i = np.searchsorted(key, offset[lq] + tq, side="right")
    i = np.clip(i, first, end)
    length = total[lq]
    wrap_b, wrap_a = i >= end, i <= first
    b = np.where(wrap_b, first, i)
    a = np.where(wrap_a, end - 1, i - 1)
    a, b = np.where(has, a, 0), np.where(has, b, 0)
    t_b = tb[b] + np.where(wrap_b, length, 0.0)
    t_a = tb[a] - np.where(wrap_a & ~wrap_b, length, 0.0)
    # One boundary vertex on the loop: the chord is the whole loop.
    arc = np.where(has, t_b - t_a, 0.0)
    middle = project_onto_curve(surface, curve.point_at(lq, 0.5 * (t_a + t_b)))
    half = 0.5 * arc
    g = row_norms(surface.grad(middle))
    converged = np.abs(surface(middle)) <= CURVE_TOL * surface.radius * np.maximum(g, 1e-300)
    d, _ = tree.query(middle)
    placed = has & converged
    ok = placed & (half >= BOUNDARY_MIN * sizing(middle)) & (d > SPLIT_KEEP * half)
    return middle, half, ok, placed


def project_onto_curve(surface: ImplicitSurface, x: np.ndarray) -> np.ndarray:
    """Newton steps along the clipping surface onto ``f = 0``.

    On the sphere: steps along the sphere, then exactly onto it. In a clip
    box: each point moves to its nearest face and steps within that face
    (clamped to the box).

    Parameters
    ----------
    surface : ImplicitSurface
    x : (k, 3) points near the curve.

    Returns
    -------
    (k, 3) points on the clipping surface (to rounding), with ``f`` near 0
    where the steps converged.
    """
    box = clip_box(surface)
    if box is not None:
        return _project_in_face(surface, box, x)
    c0, R = surface.centre, surface.radius

    def onto_sphere(y):
        d = y - c0
        return c0 + R * d / row_norms(d)[:, None]

    x = onto_sphere(x)
    for _ in range(PROJECT_ITERATIONS):
        f = surface(x)
        n = (x - c0) / R
        g = surface.grad(x)
        gt = g - np.einsum("ij,ij->i", g, n)[:, None] * n
        x, done = _newton_step(x, f, gt, 0.05 * R)
        x = onto_sphere(x)
        if done:
            break
    return x


def _project_in_face(surface: ImplicitSurface, box: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Newton steps onto ``f = 0`` within the nearest face of the box."""
    lo, hi = box
    R = surface.radius
    x = np.clip(np.asarray(x, dtype=np.float64).reshape(-1, 3), lo, hi)
    rows = np.arange(len(x))
    k = np.argmin(np.concatenate([x - lo, hi - x], axis=1), axis=1)
    axis = k % 3
    plane = np.where(k < 3, lo[axis], hi[axis])
    x[rows, axis] = plane
    for _ in range(PROJECT_ITERATIONS):
        if len(x) == 0:
            break
        f = surface(x)
        g = surface.grad(x)
        g[rows, axis] = 0.0  # the gradient within the face
        x, done = _newton_step(x, f, g, 0.05 * R)
        x = np.clip(x, lo, hi)
        x[rows, axis] = plane
        if done:
            break
    return x


def _newton_step(
    x: np.ndarray, f: np.ndarray, g: np.ndarray, cap: float
) -> tuple[np.ndarray, bool]:
    """One damped Newton step towards ``f = 0`` along ``g``; True when every
    step was negligible (below 1e-13 of ``cap / 0.05``)."""
    gn2 = np.einsum("ij,ij->i", g, g)
    moving = gn2 > 0
    step = np.zeros_like(x)
    step[moving] = -(f[moving] / gn2[moving])[:, None] * g[moving]
    x, step_len = damped_step(x, step, cap)
    return x, bool(np.all(step_len < 1e-13 * cap / 0.05))
