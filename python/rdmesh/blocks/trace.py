"""The curves where the isosurface meets one block face: traced once, on a grid of the face.

The face (a rectangle of a sample plane) gets a grid whose lines along each
axis are the face's ends and, between them, lines at ``(i + 0.382) / cells``
of its length (an irrational shift, as :func:`rdmesh.sampling.boundary.box_grid`
does, so that round coordinates miss the grid points); the cells are at most
``h`` wide. Each quad is split along one diagonal and the curve ``f = 0`` is
traced by marching triangles: every grid edge whose ends differ in sign
(``f < 0`` inside; ``f = 0`` counts as outside, everywhere the same) gets its
crossing by a root search along the edge, and each triangle joins its two
crossings. Crossings on the face's sides are where the curve crosses a block
edge: the ends of its open pieces (corners). Every face sharing a block edge
has the same grid points along it (the lines depend only on that edge's
extent) and evaluates the same ``f`` (:mod:`rdmesh.blocks.field`), so the
corners of all faces around a block edge are the same points, bit for bit.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import elementwise
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from .._newton import damped_step
from .._vectors import row_norms
from .field import Field
from .layout import Face, Layout, others

log = logging.getLogger("rdmesh")

#: Inner grid lines sit at (i + SHIFT) / cells of a face's side.
SHIFT = (3.0 - np.sqrt(5.0)) / 2.0
#: Root search along a grid edge: bracket width, as a fraction of the edge.
EDGE_ROOT_TOL = 1e-14
#: Consecutive crossings closer than this, times the grid's spacing, are one.
THIN = 1e-3


@dataclass
class FaceTrace:
    """The curves of ``f = 0`` on one face.

    Attributes
    ----------
    face : the face's key.
    curves : list of (m, 3) polylines of points on the curve, in order; an
        open one runs from a corner on one side of the face to another.
    closed : list of bool, per curve.
    inside : whether some grid point of the face is inside (``f < 0``).
    points : number of grid points.
    """

    face: Face
    curves: list[np.ndarray] = field(default_factory=list)
    closed: list[bool] = field(default_factory=list)
    inside: bool = False
    points: int = 0


def grid_lines(i0: int, i1: int, step: float) -> np.ndarray:
    """Sample-index positions of a face grid's lines between samples ``i0`` and
    ``i1``: both ends, and shifted inner lines at most ``step`` apart."""
    cells = max(1, int(np.ceil((i1 - i0) / step)))
    t = (np.arange(cells) + SHIFT) / cells
    return np.r_[float(i0), i0 + (i1 - i0) * t, float(i1)]


def face_grid(layout: Layout, face: Face, h: float) -> tuple[np.ndarray, int, int]:
    """The grid points of a face ``(nb, nc, 3)`` (physical), at most ``h`` apart."""
    a, plane, (b0, b1), (c0, c1) = layout.rect(face)
    b, c = others(a)
    ub = grid_lines(b0, b1, h / layout.spacing[b])
    uc = grid_lines(c0, c1, h / layout.spacing[c])
    pts = np.empty((len(ub), len(uc), 3))
    pts[..., a] = layout.coord(a, plane)
    pts[..., b] = layout.coord(b, ub)[:, None]
    pts[..., c] = layout.coord(c, uc)[None, :]
    return pts, len(ub), len(uc)


def trace_face(fld: Field, layout: Layout, face: Face, h: float, radius: float) -> FaceTrace:
    """Trace ``f = 0`` on a face with a grid of spacing at most ``h``; each
    piece is then refined where it bends (:func:`refine_polyline`)."""
    pts, nb, nc = face_grid(layout, face, h)
    x = pts.reshape(-1, 3)
    inside = fld.f(x) < 0
    out = FaceTrace(face, inside=bool(inside.any()), points=len(x))
    if inside.all() or not inside.any():
        return out
    ends, tri_edges, border = _grid_edges(nb, nc)
    cut = inside[ends[:, 0]] != inside[ends[:, 1]]
    cut_id = np.full(len(ends), -1)
    cut_id[cut] = np.arange(int(cut.sum()))
    crossing = edge_roots(fld, x[ends[cut, 0]], x[ends[cut, 1]])
    ids = cut_id[tri_edges]
    two = (ids >= 0).sum(axis=1) == 2
    pairs = np.sort(ids[two], axis=1)[:, 1:]
    order, size, is_open = _order(pairs, len(crossing))
    on_side = border[cut]
    for k, chain in enumerate(np.split(order, np.cumsum(size)[:-1])):
        p = crossing[chain]
        keep = _thin(p, on_side[chain], THIN * h)
        p = p[keep]
        if (is_open[k] and len(p) < 2) or (not is_open[k] and len(p) < 3):
            continue
        p = refine_polyline(fld, layout, face, p, not is_open[k], radius)
        out.curves.append(p)
        out.closed.append(not bool(is_open[k]))
    return out


#: A segment of a traced curve is split while its middle, projected onto the
#: curve, lies farther than this from the segment (times its length) ...
SAGITTA = 0.02
#: ... at most this many times over ...
REFINE_ROUNDS = 10
#: ... and not below this length (times R).
REFINE_FLOOR = 1e-6


def refine_polyline(
    fld: Field, layout: Layout, face: Face, p: np.ndarray, closed: bool, radius: float
) -> np.ndarray:
    """A traced piece with projected middles inserted where it bends, so that
    it strays from the curve by at most :data:`SAGITTA` of each segment: the
    balls placed on it later move little when projected onto the curve (a
    small loop, traced with a few points, would otherwise move its balls by
    more than their size)."""
    for _ in range(REFINE_ROUNDS):
        q = np.r_[p, p[:1]] if closed else p
        mid = 0.5 * (q[:-1] + q[1:])
        ell = row_norms(q[1:] - q[:-1])
        onto, ok = project_on_face(fld, layout, face, mid, radius)
        add = ok & (row_norms(onto - mid) > SAGITTA * ell) & (ell > REFINE_FLOOR * radius)
        if not add.any():
            break
        p = np.insert(p, np.flatnonzero(add) + 1, onto[add], axis=0)
    return p


#: Newton steps projecting a point onto the curve within its face.
PROJECT_ITERATIONS = 40
#: A point is on the curve when |f| / |grad f| is below this, times R.
CURVE_TOL = 1e-10


def project_on_face(
    fld: Field, layout: Layout, face: Face, x: np.ndarray, radius: float
) -> tuple[np.ndarray, np.ndarray]:
    """Newton steps onto ``f = 0`` within a face's plane, clamped to the face.

    Each point stops on its own (when its step is negligible), so the result
    for a point does not depend on the others. Returns the points and which
    converged onto the curve (``|f| / |grad f| <= CURVE_TOL R``)."""
    a, _, (b0, b1), (c0, c1) = layout.rect(face)
    b, c = others(a)
    lo = np.array([0.0, 0.0, 0.0])
    hi = np.array([0.0, 0.0, 0.0])
    lo[b], hi[b] = layout.coord(b, b0), layout.coord(b, b1)
    lo[c], hi[c] = layout.coord(c, c0), layout.coord(c, c1)
    x = np.array(x, dtype=np.float64).reshape(-1, 3)
    plane = float(layout.coord(a, layout.rect(face)[1]))
    x[:, a] = plane
    cap = 0.05 * radius
    active = np.ones(len(x), bool)
    for _ in range(PROJECT_ITERATIONS):
        if not active.any():
            break
        y = x[active]
        f, g = fld.f(y), fld.gradient(y)
        g[:, a] = 0.0
        gn2 = np.einsum("ij,ij->i", g, g)
        step = np.zeros_like(y)
        ok = gn2 > 0
        step[ok] = -(f[ok] / gn2[ok])[:, None] * g[ok]
        y, length = damped_step(y, step, cap)
        y[:, b] = np.clip(y[:, b], lo[b], hi[b])
        y[:, c] = np.clip(y[:, c], lo[c], hi[c])
        y[:, a] = plane
        x[active] = y
        done = length < 1e-13 * radius
        active[np.flatnonzero(active)[done]] = False
    f = fld.f(x)
    g = fld.gradient(x)
    g[:, a] = 0.0
    on = np.abs(f) <= CURVE_TOL * radius * np.maximum(row_norms(g), 1e-300)
    return x, on


def _grid_edges(nb: int, nc: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A grid's edges ``(E, 2)`` (lower end first), each triangle's three edges
    ``(T, 3)``, and which edges lie on the face's sides ``(E,)``."""
    node = np.arange(nb * nc).reshape(nb, nc)
    hz = np.c_[node[:-1, :].ravel(), node[1:, :].ravel()]  # along b
    vt = np.c_[node[:, :-1].ravel(), node[:, 1:].ravel()]  # along c
    dg = np.c_[node[:-1, :-1].ravel(), node[1:, 1:].ravel()]
    nh, nv = len(hz), len(vt)
    ends = np.concatenate([hz, vt, dg])
    i, j = np.meshgrid(np.arange(nb - 1), np.arange(nc - 1), indexing="ij")
    i, j = i.ravel(), j.ravel()
    h_ij, h_ij1 = i * nc + j, i * nc + j + 1
    v_ij, v_i1j = nh + i * (nc - 1) + j, nh + (i + 1) * (nc - 1) + j
    d_ij = nh + nv + i * (nc - 1) + j
    tri = np.concatenate([np.c_[h_ij, v_i1j, d_ij], np.c_[d_ij, h_ij1, v_ij]])
    ih, jh = np.divmod(np.arange(nh), nc)
    iv, jv = np.divmod(np.arange(nv), nc - 1)
    border = np.concatenate(
        [(jh == 0) | (jh == nc - 1), (iv == 0) | (iv == nb - 1), np.zeros(len(dg), bool)]
    )
    return ends, tri, border


def edge_roots(fld: Field, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The crossing of ``f`` on each segment from ``p`` to ``q`` ``(k, 3)`` (a
    sign change between its ends), by bracketing; each segment's search uses
    only its own values, so the same segment gives the same point in any batch."""
    if len(p) == 0:
        return np.zeros((0, 3))

    def point(t, px, py, pz, qx, qy, qz):
        return np.stack([px + t * (qx - px), py + t * (qy - py), pz + t * (qz - pz)], axis=-1)

    def g(t, *args):
        return fld.f(point(t, *args).reshape(-1, 3)).reshape(np.shape(t))

    args = (p[:, 0], p[:, 1], p[:, 2], q[:, 0], q[:, 1], q[:, 2])
    res = elementwise.find_root(
        g, (np.zeros(len(p)), np.ones(len(p))), args=args,
        tolerances={"xrtol": 0.0, "xatol": EDGE_ROOT_TOL}, maxiter=200,
    )  # fmt: skip
    t = res.x.copy()
    failed = ~np.isfinite(t)
    if failed.any():
        # f rounds to 0 at an end: that end is the crossing.
        sub = tuple(a[failed] for a in args)
        fa = np.abs(g(np.zeros(int(failed.sum())), *sub))
        fb = np.abs(g(np.ones(int(failed.sum())), *sub))
        t[failed] = np.where(fa <= fb, 0.0, 1.0)
    return point(t, *args)


def _order(pairs: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Crossings joined by ``pairs`` in order along each piece (every crossing
    has one or two neighbours). Returns the crossings in order, piece after
    piece, the size of each piece, and whether each piece is open (it then
    starts at its lowest end)."""
    src = np.concatenate([pairs[:, 0], pairs[:, 1]])
    dst = np.concatenate([pairs[:, 1], pairs[:, 0]])
    o = np.lexsort((dst, src))
    src, dst = src[o], dst[o]
    deg = np.bincount(src, minlength=m)
    first = np.searchsorted(src, np.arange(m))
    nb = np.full((m, 2), -1)
    nb[deg > 0, 0] = dst[first[deg > 0]]
    nb[deg > 1, 1] = dst[first[deg > 1] + 1]
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(m, m))
    n, label = connected_components(g, directed=False)
    ids = np.arange(m)
    start = np.full(n, m)
    np.minimum.at(start, label[deg == 1], ids[deg == 1])
    is_open = start < m
    lowest = np.full(n, m)
    np.minimum.at(lowest, label, ids)
    start = np.where(is_open, start, lowest)
    size = np.bincount(label, minlength=n)
    steps = np.zeros((int(size.max()), n), np.int64)
    prev, cur = np.full(n, -1), start.copy()
    for k in range(int(size.max())):
        steps[k] = cur
        nxt = np.where(nb[cur, 0] != prev, nb[cur, 0], nb[cur, 1])
        nxt = np.where(nxt < 0, cur, nxt)
        prev, cur = cur, nxt
    valid = np.arange(int(size.max()))[:, None] < size[None, :]
    return steps.T[valid.T], size, is_open


def _thin(p: np.ndarray, fixed: np.ndarray, tol: float) -> np.ndarray:
    """Which points of a polyline to keep: not within ``tol`` of the previous
    one, unless ``fixed`` (the corners at its ends)."""
    if len(p) < 2:
        return np.ones(len(p), bool)
    keep = np.r_[True, row_norms(np.diff(p, axis=0)) > tol] | fixed
    kept = np.flatnonzero(keep)
    # A fixed last point close to the one kept before it: that one goes.
    if fixed[-1] and len(kept) > 2 and np.linalg.norm(p[kept[-1]] - p[kept[-2]]) <= tol:
        keep[kept[-2]] = fixed[kept[-2]]
    return keep
