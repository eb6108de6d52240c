"""Proven seeds on every component of a volume's isosurface (issue 30).

For :class:`~rdmesh.VolumeSurface` with ``border="closed"`` the inside is
``U = {u > 0}`` within the open box of the samples, where
``u = s (v - isovalue)`` is the interpolant ``v`` shifted and signed
(``s = 1`` for ``inside="greater"``, ``-1`` for "less"). The surface is the
boundary of ``U``; outside the box ``f > 0``.

**Regions.** Call *region* a connected component of ``U`` (inside) or a
component of the outside that does not reach the box (a cavity). Each
component ``S`` of the surface separates exactly two regions, and the
regions form a tree rooted at the unbounded outside; ``S`` is the outer
boundary of the region on its bounded side. So a point on the outer
boundary of every region other than the root is a point on every component
of the surface.

**A point in every region.**

- *Linear* (trilinear) interpolation: a multilinear function on a cell is
  linear along each axis, so from any point ``x`` of a cell one can move
  along an axis without decreasing ``u`` to a face, then to an edge, then to a
  corner: every component of ``{u > 0}`` contains a grid point with ``u > 0``,
  and every cavity a grid point with ``u < 0``. Two grid points adjacent
  along an axis with ``u > 0`` at both are joined by the grid edge, on which
  ``u`` is linear, so they lie in one region: one grid point per 6-connected
  component of the grid points above (and, for cavities, below and not
  touching the box's faces) has a point in every region.
- *Cubic* B-spline: on a cell, ``v`` lies within the range of its 64
  coefficients (the B-spline's convex hull property), and each partial
  derivative within the range of the 48 differences of coefficients along
  its axis. A region's maximum of ``u`` (minimum for a cavity) is a
  critical point of the mirrored spline (its normal derivative is 0 on the
  box's faces). Cells with every coefficient above 0 lie in one region each,
  and touching ones in the same one: one per 26-connected component of them.
  Every other cell that could hold a maximum above 0 (some coefficient above
  0, every derivative range holding 0) is split in Bezier form (de
  Casteljau), dropping pieces whose Bezier coefficients are all at most 0 or
  whose derivative coefficients exclude 0 along an axis, keeping the centre of
  pieces whose coefficients are all above 0, until none is left or the depth
  cap is reached (then the pieces left are *unresolved*). The same with
  ``-u`` finds the cavities.

**From a point to its region's outer boundary.** The segment from a
region's point ``p`` along ``-x`` to the box's face leaves the region's
bounded side, so it crosses the region's outer boundary where ``u`` changes
sign, or ends on the face with ``u > 0`` (the face is then surface). Along
a line parallel to ``x`` the interpolant is a 1-D spline of the same degree;
its sign changes are isolated per piece by Descartes' rule on its Bezier
coefficients (one sign change: exactly one root) and subdivision, and located
by bisection. All of them are seeds, with the face point (and ``p`` itself
when ``p``, a grid point, lies on a face of the box with ``u > 0``, where it
is on the surface).

When nothing is unresolved, this proves that every component of the
interpolant's closed isosurface gets a seed, for an isovalue that is a
regular value of the interpolant (no sample equal to it for linear).
Whether the mesh then has every component and the right topology still
rests on the refinement (sampled tests), as for any surface.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from .discovery import Discovery

if TYPE_CHECKING:
    from ..surfaces.volume import VolumeSurface

log = logging.getLogger("rdmesh")

#: Depth of the Bezier subdivision of a cell (pieces of 2**-depth cells).
MAX_DEPTH = 10
#: Bezier pieces kept at one level at most (then unresolved).
MAX_PIECES = 1 << 18
#: Rays whose lines are built at once (memory: rays x samples x 16 floats).
RAY_CHUNK = 256
#: Halvings of a 1-D piece with several sign changes (then unresolved).
RAY_DEPTH = 40
#: Bisection steps that locate a root on a piece (relative width 2**-52).
BISECTIONS = 52

#: Cubic B-spline segment to Bezier: b = M @ (c[i-1], c[i], c[i+1], c[i+2]).
_B2B = np.array([[1, 4, 1, 0], [0, 4, 2, 0], [0, 2, 4, 0], [0, 1, 4, 1]], float) / 6.0
#: de Casteljau halves of a cubic Bezier: left and right children.
_LEFT = np.array([[8, 0, 0, 0], [4, 4, 0, 0], [2, 4, 2, 0], [1, 3, 3, 1]], float) / 8.0
_HALVES = np.stack([_LEFT, _LEFT[::-1, ::-1]])
_CHILDREN = np.array([[a, b, c] for a in (0, 1) for b in (0, 1) for c in (0, 1)], float)


def volume_components(surface: VolumeSurface) -> Discovery:
    """Seeds with a point on every component of a closed volume's isosurface.

    Parameters
    ----------
    surface : VolumeSurface
        With ``border="closed"``.

    Returns
    -------
    Discovery
        ``points`` are the seeds (world coordinates, on the surface up to
        rounding), ``proven`` is True when the argument of this module holds
        (nothing unresolved, the isovalue not a sample for linear), and
        ``unresolved`` are the centres of the cells or ray pieces left
        undecided. ``boxes`` counts the regions' points (rays shot).
    """
    coef = surface._sampler.coefficients()
    u = (coef - surface.isovalue) * surface._sign
    del coef
    degree = surface.degree
    if degree == 1:
        reps, unresolved, side = _linear_points(u), np.zeros((0, 3)), 1.0
        degenerate = bool((u == 0).any())
    else:
        reps, unresolved, side = _cubic_points(u)
        degenerate = False
    seeds, stuck = _ray_seeds(u, degree, reps)
    unresolved = np.concatenate([unresolved, stuck])
    world = surface.origin + seeds * surface.spacing
    world = np.unique(world, axis=0)
    proven = not len(unresolved) and not degenerate
    log.info(
        "volume components: %d region points, %d seeds%s",
        len(reps),
        len(world),
        ""
        if proven
        else f", {len(unresolved)} unresolved"
        + (", a sample at the isovalue" if degenerate else ""),
    )
    if degenerate:
        basis = (
            "a sample equals the isovalue: the linear interpolant's grid-point argument "
            "does not decide the regions there; components may be missed"
        )
    elif proven:
        basis = (
            "the interpolant's regions (a point in each: grid points for linear "
            "interpolation, the B-spline's coefficient bounds and Bezier subdivision for "
            "cubic) and every sign change on a segment from each to the box: a seed on "
            "every component"
        )
    else:
        basis = (
            "Bezier subdivision or a ray's root isolation left pieces unresolved there: "
            "components may be missed there"
        )
    return Discovery(
        points=world,
        proven=proven,
        unresolved=surface.origin + unresolved * surface.spacing,
        boxes=len(reps),
        side=float(side * surface.spacing.min()),
        evaluations=0,
        basis=basis,
    )


# -- a point in every region -------------------------------------------------------


def _first_of_labels(labels: np.ndarray, n: int, drop: np.ndarray | None = None) -> np.ndarray:
    """The first index (C order) of each label 1..n, ``(k, 3)`` int, without the dropped labels."""
    flat = labels.ravel()
    where = np.flatnonzero(flat)
    lab, first = np.unique(flat[where], return_index=True)
    if drop is not None:
        keep = ~np.isin(lab, drop)
        first = first[keep]
    return np.column_stack(np.unravel_index(where[first], labels.shape))


def _boundary_labels(labels: np.ndarray) -> np.ndarray:
    """Labels present on the faces of the array."""
    faces = [labels[0], labels[-1], labels[:, 0], labels[:, -1], labels[:, :, 0], labels[:, :, -1]]
    return np.unique(np.concatenate([f.ravel() for f in faces]))


def _linear_points(u: np.ndarray) -> np.ndarray:
    """Grid points (index coordinates, ``(k, 3)`` float): one per 6-connected
    component of ``u > 0``, and one per component of ``u < 0`` off the faces."""
    lab, n = ndimage.label(u > 0)
    inside = _first_of_labels(lab, n)
    lab, n = ndimage.label(u < 0)
    cavity = _first_of_labels(lab, n, drop=_boundary_labels(lab))
    return np.concatenate([inside, cavity]).astype(np.float64)


def _window(a: np.ndarray, sizes: tuple[int, int, int], op) -> np.ndarray:
    """``op`` (np.minimum or np.maximum) over every ``sizes`` window, separably."""
    for axis, k in enumerate(sizes):
        n = a.shape[axis] - k + 1
        parts = [np.take(a, np.arange(j, j + n), axis=axis) for j in range(k)]
        a = op.reduce(parts)
    return a


def _cubic_points(u: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Cell-index points, one in every region of the cubic interpolant, the
    unresolved pieces' centres, and the smallest piece's side (cells)."""
    p = np.pad(u, 1, mode="reflect")  # cell i uses p[i:i+4] on each axis
    vmin = _window(p, (4, 4, 4), np.minimum)
    vmax = _window(p, (4, 4, 4), np.maximum)
    flat_any = np.ones(vmin.shape, bool)  # every derivative range holds 0
    for axis in range(3):
        d = np.diff(p, axis=axis)
        sizes = tuple(3 if a == axis else 4 for a in range(3))
        flat_any &= (_window(d, sizes, np.minimum) <= 0) & (_window(d, sizes, np.maximum) >= 0)
    points, unresolved, side = [], [], 1.0
    full = np.ones((3, 3, 3), bool)
    for sign, whole, far in ((1.0, vmin > 0, vmax <= 0), (-1.0, vmax < 0, vmin >= 0)):
        lab, n = ndimage.label(whole, structure=full)
        drop = _boundary_labels(lab) if sign < 0 else None
        points.append(_first_of_labels(lab, n, drop) + 0.5)
        cand = np.argwhere(~whole & ~far & flat_any)
        lo, h, stuck = _extremum_pieces(p, cand, sign)
        points.append(_one_per_region(lo, h, whole))
        unresolved.append(stuck)
        if len(h):
            side = min(side, float(h.min()))
    return np.concatenate(points), np.concatenate(unresolved), side


def _bezier_cells(p: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Bezier coefficients ``(m, 4, 4, 4)`` of the padded coefficients' cells."""
    o = np.arange(4)
    i, j, k = (cells[:, a, None] + o for a in range(3))
    c = p[i[:, :, None, None], j[:, None, :, None], k[:, None, None, :]]
    return np.einsum("ai,bj,ck,mijk->mabc", _B2B, _B2B, _B2B, c, optimize=True)


def _extremum_pieces(
    p: np.ndarray, cells: np.ndarray, sign: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bezier pieces with ``sign * u > 0`` throughout that may hold a maximum
    of ``sign * u``: their low corners ``(k, 3)`` and sides ``(k,)`` in cell
    units; and the unresolved pieces' centres."""
    los, sides, stuck = [np.zeros((0, 3))], [np.zeros(0)], [np.zeros((0, 3))]
    for start in range(0, len(cells), 4096):
        chunk = cells[start : start + 4096]
        bez = sign * _bezier_cells(p, chunk)
        lo, h = chunk.astype(np.float64), 1.0
        for depth in range(MAX_DEPTH + 1):
            flat = bez.reshape(len(bez), -1)
            whole = flat.min(axis=1) > 0
            los.append(lo[whole])
            sides.append(np.full(int(whole.sum()), h))
            keep = ~whole & (flat.max(axis=1) > 0)
            for axis in (1, 2, 3):
                d = np.diff(bez, axis=axis).reshape(len(bez), -1)
                keep &= (d.min(axis=1) <= 0) & (d.max(axis=1) >= 0)
            bez, lo = bez[keep], lo[keep]
            if not len(bez):
                break
            if depth == MAX_DEPTH or 8 * len(bez) > MAX_PIECES:
                stuck.append(lo + 0.5 * h)
                break
            bez = np.einsum("arc,mcjk->marjk", _HALVES, bez)
            bez = np.einsum("brc,maick->mabirk", _HALVES, bez)
            bez = np.einsum("gsc,mabirc->mabgirs", _HALVES, bez).reshape(-1, 4, 4, 4)
            h *= 0.5
            lo = (lo[:, None, :] + h * _CHILDREN).reshape(-1, 3)
    return np.concatenate(los), np.concatenate(sides), np.concatenate(stuck)


def _one_per_region(lo: np.ndarray, h: np.ndarray, whole: np.ndarray) -> np.ndarray:
    """Centres of the pieces ``[lo, lo + h]`` (all on one side of 0) that touch
    no whole cell, one per group of touching pieces: touching closed boxes on
    one side of 0 lie in one region."""
    if not len(lo):
        return np.zeros((0, 3))
    hi = lo + h[:, None]
    limit = np.asarray(whole.shape) - 1
    # The cells a closed piece touches: from ceil(lo) - 1 to floor(hi) on each axis.
    first = np.clip(np.ceil(lo).astype(np.int64) - 1, 0, limit)
    last = np.clip(np.floor(hi).astype(np.int64), 0, limit)
    touches = np.zeros(len(lo), bool)
    for corner in _CHILDREN.astype(np.int64):
        c = np.where(corner == 1, last, first)
        touches |= whole[c[:, 0], c[:, 1], c[:, 2]]
    lo, hi, h = lo[~touches], hi[~touches], h[~touches]
    if not len(lo):
        return np.zeros((0, 3))
    centre = 0.5 * (lo + hi)
    pairs = cKDTree(centre).query_pairs(float(h.max()) * 3**0.5 + 1e-12, output_type="ndarray")
    if len(pairs):
        a, b = pairs[:, 0], pairs[:, 1]
        meet = np.all((lo[a] <= hi[b]) & (lo[b] <= hi[a]), axis=1)
        pairs = pairs[meet]
    n = len(lo)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, comp = connected_components(graph, directed=False)
    _, first_of = np.unique(comp, return_index=True)
    return centre[first_of]


# -- from a region's point to its outer boundary ------------------------------------


def _ray_seeds(u: np.ndarray, degree: int, reps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every sign change of ``u`` on the segments from ``reps`` (index
    coordinates) along ``-x`` to the box, the face points with ``u > 0``,
    and the grid points on a face; returns ``(seeds, unresolved)``."""
    from ..surfaces.volume import _taps

    shape = np.asarray(u.shape)
    on_face = np.any((reps <= 0) | (reps >= shape - 1), axis=1)
    seeds = [reps[on_face]]
    rays = reps[~on_face]
    stuck = [np.zeros((0, 3))]
    n0 = u.shape[0]
    for start in range(0, len(rays), RAY_CHUNK):
        q = rays[start : start + RAY_CHUNK]
        iy, wy, _ = _taps(q[:, 1], u.shape[1], degree, False)
        iz, wz, _ = _taps(q[:, 2], u.shape[2], degree, False)
        cols = u[:, iy[:, :, None], iz[:, None, :]]  # (n0, r, k, k)
        line = np.einsum("xrjk,rj,rk->rx", cols, wy, wz)
        if degree == 3:
            pad = np.pad(line, ((0, 0), (1, 1)), mode="reflect")
            segs = np.stack([pad[:, i : i + n0 - 1] for i in range(4)], axis=-1) @ _B2B.T
        else:
            segs = np.stack([line[:, :-1], line[:, 1:]], axis=-1)
        last = np.minimum(np.floor(q[:, 0]), n0 - 2).astype(np.int64)
        ray, seg = np.nonzero(np.arange(n0 - 1)[None, :] <= last[:, None])
        t, bad = _roots(segs[ray, seg])
        x = seg[t[0]] + t[1]
        seeds.append(np.column_stack([x, q[ray[t[0]], 1], q[ray[t[0]], 2]]))
        face = segs[:, 0, 0] > 0  # u at x = 0: the face is surface there
        seeds.append(np.column_stack([np.zeros(face.sum()), q[face, 1], q[face, 2]]))
        if len(bad[0]):
            centre = seg[bad[0]] + bad[1]
            stuck.append(np.column_stack([centre, q[ray[bad[0]], 1], q[ray[bad[0]], 2]]))
    return np.concatenate(seeds), np.concatenate(stuck)


def _roots(bez: np.ndarray) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """Every sign change of 1-D Bezier pieces ``(m, d + 1)`` on ``[0, 1]``
    (zero counts as outside): ``((piece, t), (piece, t_centre of unresolved))``."""
    d = bez.shape[1] - 1
    half = _HALVES if d == 3 else np.array([[[1, 0], [0.5, 0.5]], [[0.5, 0.5], [0, 1]]])
    idx = np.arange(len(bez))
    lo, h = np.zeros(len(bez)), 1.0
    out_i, out_t, bad_i, bad_t = [], [], [], []
    for depth in range(RAY_DEPTH + 1):
        pos = bez > 0
        var = np.count_nonzero(pos[:, 1:] != pos[:, :-1], axis=1)
        one = var == 1
        if one.any():
            out_i.append(idx[one])
            out_t.append(lo[one] + h * _bisect(bez[one]))
        many = var >= 2
        bez, idx, lo = bez[many], idx[many], lo[many]
        if not len(bez):
            break
        if depth == RAY_DEPTH:
            bad_i.append(idx)
            bad_t.append(lo + 0.5 * h)
            break
        bez = np.einsum("arc,mc->mar", half, bez).reshape(-1, d + 1)
        h *= 0.5
        idx = np.repeat(idx, 2)
        lo = (lo[:, None] + h * np.arange(2)).ravel()
    cat = lambda a, dt: np.concatenate(a) if a else np.zeros(0, dt)  # noqa: E731
    return (cat(out_i, np.int64), cat(out_t, float)), (cat(bad_i, np.int64), cat(bad_t, float))


def _bisect(bez: np.ndarray) -> np.ndarray:
    """The root of each Bezier piece whose end values differ in sign, ``(m,)`` in [0, 1]."""
    a, b = np.zeros(len(bez)), np.ones(len(bez))
    inside_a = bez[:, 0] > 0
    for _ in range(BISECTIONS):
        m = 0.5 * (a + b)
        inside_m = _evaluate(bez, m) > 0
        same = inside_m == inside_a
        a = np.where(same, m, a)
        b = np.where(same, b, m)
    return 0.5 * (a + b)


def _evaluate(bez: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Bezier pieces ``(m, d + 1)`` at ``t`` ``(m,)`` by de Casteljau."""
    b = bez.copy()
    tt = t[:, None]
    for k in range(bez.shape[1] - 1, 0, -1):
        b = (1 - tt) * b[:, :k] + tt * b[:, 1 : k + 1]
    return b[:, 0]
