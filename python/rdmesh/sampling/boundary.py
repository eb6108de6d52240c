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
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import elementwise
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from .._newton import damped_step
from .._vectors import row_norms
from ..surfaces.oracle import ImplicitSurface

log = logging.getLogger("rdmesh")

#: Points of the sphere grid: at most about this many, at least about MIN_POINTS.
MAX_POINTS, MIN_POINTS = 400_000, 4_000
#: Newton steps projecting curve points onto f = 0 on the sphere.
PROJECT_ITERATIONS = 30
#: Curve points per size bound when no distance bound tightens it.
PER_BOUND = 1.0
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
    """

    points: np.ndarray
    loop: np.ndarray
    lengths: np.ndarray
    spacing: float
    size: float
    dense: np.ndarray
    gap: float = 0.0

    @property
    def n_loops(self) -> int:
        return len(self.lengths)


def boundary_curve(
    surface: ImplicitSurface,
    size: float,
    distance: float | None = None,
    resolution: int = 64,
    sizing: Callable[[np.ndarray], np.ndarray] | None = None,
) -> BoundaryCurve:
    """Find and sample the curve ``f = 0`` on the bounding sphere.

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
        Empty when ``f`` does not change sign on the sampled sphere.
    """
    c0, R = surface.centre, surface.radius
    # Spacing: a quarter of the size bound, and finer than the grid scan.
    h = min(0.25 * size, 2.0 * R / resolution)
    # A grid of about 2 pi^2 / h^2 points, within the point budget.
    lo, hi = np.sqrt(2.0 * np.pi**2 / MAX_POINTS), np.sqrt(2.0 * np.pi**2 / MIN_POINTS)
    u, ends, tri_edges = sphere_grid(float(np.clip(h / R, lo, hi)))
    n = len(u)
    h = np.sqrt(4.0 * np.pi / n) * R
    inside = surface(c0 + R * u) < 0
    a, b = ends[:, 0], ends[:, 1]
    cut = inside[a] != inside[b]
    gap = float(R * row_norms(u[a] - u[b]).max())
    empty = BoundaryCurve(
        np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros(0), h, size, np.zeros((0, 3))
    )
    if not cut.any():
        return empty
    cut_id = np.full(len(ends), -1)
    cut_id[cut] = np.arange(int(cut.sum()))
    crossing = _arc_roots(surface, u[a[cut]], u[b[cut]])
    # Marching triangles: a triangle with a sign change has exactly two cut edges.
    ids = cut_id[tri_edges]  # (T, 3) cut index of each triangle edge
    has = ids >= 0
    two = has.sum(axis=1) == 2
    pairs = np.sort(ids[two], axis=1)[:, 1:]  # the two non-negative ids
    m = len(crossing)
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(m, m))
    n_loops, label = connected_components(g, directed=False)
    order, loop = _loop_order(pairs, label, n_loops, m)
    pts = crossing[order]
    local = np.full(len(pts), size) if sizing is None else np.minimum(size, sizing(pts))
    points, which, lengths = _resample(pts, loop, n_loops, local, distance)
    points = project_onto_curve(surface, points)
    # A projection that did not converge is not on the surface: dropped.
    g = row_norms(surface.grad(points))
    on = np.abs(surface(points)) <= CURVE_TOL * R * np.maximum(g, 1e-300)
    if not on.all():
        log.warning(
            "boundary curve: %d of %d samples did not converge onto the curve and were "
            "dropped (the surface may be tangent to the sphere there)",
            int((~on).sum()),
            len(on),
        )
        points, which = points[on], which[on]
    log.info(
        "boundary curve: %d loops on the sphere (%d sphere points), %d samples",
        n_loops,
        n,
        len(points),
    )
    return BoundaryCurve(points, which, lengths, h, size, pts, gap)


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
    c0, R = surface.centre, surface.radius

    def point(t, px, py, pz, qx, qy, qz):
        x = np.stack([px + t * (qx - px), py + t * (qy - py), pz + t * (qz - pz)], axis=-1)
        x = x / np.linalg.norm(x, axis=-1, keepdims=True)
        return c0 + R * x

    def g(t, *args):
        return surface(point(t, *args).reshape(-1, 3)).reshape(np.shape(t))

    args = (p[:, 0], p[:, 1], p[:, 2], q[:, 0], q[:, 1], q[:, 2])
    res = elementwise.find_root(
        g, (np.zeros(len(p)), np.ones(len(p))), args=args, tolerances={"xrtol": 0.0}
    )
    t = res.x
    # Status -2 (the iteration cap at this tight tolerance) still leaves a
    # converged bracket; a NaN comes where f rounds to 0 at an end (the curve
    # runs through a grid point): that end is the crossing.
    failed = ~np.isfinite(t)
    if failed.any():
        fa = np.abs(surface(c0 + R * p[failed]))
        fb = np.abs(surface(c0 + R * q[failed]))
        t = t.copy()
        t[failed] = np.where(fa <= fb, 0.0, 1.0)
        log.debug("boundary curve: %d arc root searches ended at a grid point", int(failed.sum()))
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


def _resample(pts, loop, n_loops, size, distance):
    """Points along each closed polyline, at most ``size`` (per point) apart
    (tighter where the turning would put a chord farther than ``distance``
    from the curve)."""
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
        prv = np.arange(len(pts)) - 1
        prv[starts] = ends - 1
        t_in, t_out = seg[prv], seg
        cos = np.einsum("ij,ij->i", t_in, t_out) / np.maximum(ell[prv] * ell, 1e-300)
        kappa = np.arccos(np.clip(cos, -1.0, 1.0)) / np.maximum(0.5 * (ell[prv] + ell), 1e-300)
        with np.errstate(divide="ignore"):
            spacing = np.minimum(size, np.sqrt(8.0 * distance / np.maximum(kappa, 1e-300)))
    # Samples per segment: its length over the local spacing, accumulated;
    # each loop gets an integer number of samples (at least 3).
    density = ell / np.minimum(spacing, spacing[nxt])
    cum = np.cumsum(density)
    base = np.r_[0.0, cum][starts]
    total = cum[ends - 1] - base
    count = np.maximum(np.ceil(total * PER_BOUND).astype(np.int64), 3)
    which = np.repeat(np.arange(n_loops), count)
    k = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    target = base[which] + total[which] * k / count[which]
    # Locate each target in its loop's cumulative density.
    before = np.r_[0.0, cum]
    j = np.searchsorted(cum, target, side="right")
    j = np.clip(j, starts[which], ends[which] - 1)
    w = (target - before[j]) / np.maximum(density[j], 1e-300)
    points = pts[j] + np.clip(w, 0.0, 1.0)[:, None] * seg[j]
    return points, which, lengths


#: A refinement point moved onto the curve is kept when it lies farther than
#: this, times its ball's radius, from every sample.
SNAP_KEEP = 0.25
#: Seeds closer than this to the sphere, times the curve's spacing, are dropped.
SEED_BAND = 0.6


def guard_boundary(
    surface: ImplicitSurface,
    curve: BoundaryCurve,
    centres: np.ndarray,
    radii: np.ndarray,
    tree: cKDTree,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Keep interior refinement points off the boundary curve.

    A sample becomes a boundary vertex when it is the nearest sample of some
    point of the curve. Every traced curve point ``c`` (the fine polyline)
    has its nearest sample at distance ``d(c)``; a refinement point ``p``
    with ``|c - p| > d(c) + gap`` for every ``c`` (``gap`` bounds the
    distance between consecutive traced points) leaves the boundary as it
    is and is inserted unchanged. Any other ``p`` is projected onto the
    curve (a 1-D refinement of the curve) and kept there when the
    projection lands within ``2 size`` of ``p`` and farther than
    ``SNAP_KEEP`` times its ball's radius from every sample. When it cannot
    be moved, it is inserted unchanged if only the margin ``gap`` caught it
    (``|c - p| > d(c)`` at every traced point), and refused otherwise.

    Parameters
    ----------
    surface : ImplicitSurface
    curve : BoundaryCurve
    centres : (k, 3) refinement points inside the ball.
    radii : (k,) their balls' radii.
    tree : KD-tree of the current samples.

    Returns
    -------
    points : (k, 3) the refinement points, moved where ``snapped``.
    snapped : (k,) bool
    keep : (k,) bool: False where a moved point would nearly repeat a sample.
    """
    k = len(centres)
    out = centres.copy()
    snapped = np.zeros(k, bool)
    keep = np.ones(k, bool)
    if k == 0 or len(curve.dense) == 0:
        return out, snapped, keep
    d_c, _ = tree.query(curve.dense)
    reach = d_c + curve.gap
    pairs = cKDTree(centres).sparse_distance_matrix(
        cKDTree(curve.dense), float(reach.max()), output_type="coo_matrix"
    )
    rows = np.unique(pairs.row[pairs.data <= reach[pairs.col]])
    if len(rows) == 0:
        return out, snapped, keep
    # Nearer to a traced point than its nearest sample, without the margin.
    closer = np.zeros(k, bool)
    closer[pairs.row[pairs.data <= d_c[pairs.col]]] = True
    moved = project_onto_curve(surface, centres[rows])
    ok = row_norms(moved - centres[rows]) < 2.0 * curve.size
    d, _ = tree.query(moved)
    ok &= d > SNAP_KEEP * radii[rows]
    out[rows[ok]] = moved[ok]
    snapped[rows[ok]] = True
    # A point that cannot be moved stays where it is when only the margin
    # caught it; otherwise it is refused.
    keep[rows[~ok & closer[rows]]] = False
    return out, snapped, keep


def project_onto_curve(surface: ImplicitSurface, x: np.ndarray) -> np.ndarray:
    """Newton steps along the sphere onto ``f = 0``, then exactly onto the sphere.

    Parameters
    ----------
    surface : ImplicitSurface
    x : (k, 3) points near the curve.

    Returns
    -------
    (k, 3) points on the sphere (to rounding), with ``f`` near 0 where the
    steps converged.
    """
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
        gn2 = np.einsum("ij,ij->i", gt, gt)
        moving = gn2 > 0
        step = np.zeros_like(x)
        step[moving] = -(f[moving] / gn2[moving])[:, None] * gt[moving]
        x, step_len = damped_step(x, step, 0.05 * R)
        x = onto_sphere(x)
        if np.all(step_len < 1e-13 * R):
            break
    return x
