"""Sharp kinks of a trilinear interpolant's isosurface, as feature curves (issue 30).

Across a grid plane the trilinear interpolant is continuous but its normal
derivative jumps: the isosurface has a crease along its curve on the plane.
Its tangential gradient is the same on both sides, so the normals on the two
sides differ only in the plane's normal component. Usually the crease is mild
and refinement copes with it. Where the two one-sided normals are far apart
(a ridge of the data at a plane of symmetry, such as the midline of a
symmetric brain template), the isosurface is a thin wedge there: a wedge looks
the same at every scale, so the topology tests fail however fine the sampling,
and refinement stops at the spacing floor, leaving the mesh unclosed.

These curves are known exactly: on a grid plane the interpolant is bilinear in
each face cell, so its isocurve there is a branch of a hyperbola, through the
crossings of the face's edges. :func:`kink_curves` returns the stretches where
the one-sided normals are at least :data:`KINK_ANGLE` apart, as feature curves
to protect with balls, each with an exact projection onto its curve (Newton in
its plane).
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ..features.graph import FeatureCurve, build_graph
from ..features.sharp_edges import chain_edges

#: The source of the curves (:attr:`rdmesh.features.graph.FeatureCurve.source`).
KINK_SOURCE = "volume kink"
#: One-sided normals at least this far apart (degrees) make a kink sharp.
KINK_ANGLE = 135.0
#: A stretch holding a sharp point is protected while its normals are at
#: least this far apart (degrees), so that it ends where the kink is mild.
KINK_LOW = 90.0
#: Points per face cell along the isocurve, ends included.
PER_CELL = 9
#: Chains turning by this (degrees) at a point are split there (a corner).
TURN = 45.0
#: Kink curves closer than this (times the grid spacing) away from a shared
#: end point: the shorter is left out.
GAP = 0.02
#: Near a shared end point, closeness counts beyond this many gaps from it.
CORNER_REACH = 4.0
#: Curves leaving a common end point closer than this (degrees) are too
#: close to protect: the shorter is left out.
MIN_MEETING = 30.0
#: The direction leaving an end is measured this far along (times the spacing).
TANGENT_REACH = 0.25
#: Rounds of leaving curves out (each round rebuilds the corners).
MAX_PASSES = 8
#: Newton steps of the projection onto a curve (the isocurve is bilinear).
NEWTON_STEPS = 6


def kink_curves(volume, angle: float = KINK_ANGLE) -> list[FeatureCurve]:
    """The sharp stretches of the isosurface's kinks on the interior grid planes.

    Parameters
    ----------
    volume : rdmesh.VolumeSurface
        With ``interpolation="linear"``.
    angle : float
        Degrees between the two one-sided normals from which a kink is sharp.

    Returns
    -------
    list of FeatureCurve
        Source ``"volume kink"``; face cells touching the box are left out
        (the box's own curve is protected there).
    """
    data = volume._sampler.coefficients()
    out: list[FeatureCurve] = []
    for axis in range(3):
        x, seg, sharp = _plane_branches(data, volume.isovalue, axis, volume.spacing, angle)
        if not len(seg):
            continue
        # Chained per axis: curves on two planes meet only at end points
        # (corners), and each keeps its plane for the projection.
        xyz, inv = np.unique(volume.origin + x * volume.spacing, axis=0, return_inverse=True)
        inv = inv.reshape(-1)
        e = inv[seg]
        e = np.unique(np.sort(e[e[:, 0] != e[:, 1]], axis=1), axis=0)
        e = _reaching(e, len(xyz), np.unique(inv[sharp]))
        chains, closed = chain_edges(xyz, e, TURN)
        project = _projection(volume, axis)
        for c, cl in zip(chains, closed, strict=True):
            label = f"volume kink {len(out)}"
            out.append(FeatureCurve(xyz[c], cl, KINK_SOURCE, project, label))
    spacing = float(volume.spacing.min())
    return _without_narrow_meetings(_apart(out, GAP * spacing), volume.radius, spacing)


def _apart(curves: list[FeatureCurve], gap: float) -> list[FeatureCurve]:
    """The curves, less the shorter of any two that come within ``gap`` of
    each other away from their common end points: their balls would have to
    be smaller than the gap there (curves on two planes that pass close to
    the grid line between them without meeting on it, two branches in a face
    near its saddle)."""
    if len(curves) < 2:
        return curves
    # Points at most a gap apart along each curve, so no close stretch is missed.
    dense = [c.point_at(np.linspace(0.0, c.length, int(c.length / gap) + 2)) for c in curves]
    pts = np.concatenate(dense)
    owner = np.concatenate([np.full(len(d), i) for i, d in enumerate(dense)])
    pairs = cKDTree(pts).query_pairs(gap, output_type="ndarray")
    pairs = pairs[owner[pairs[:, 0]] != owner[pairs[:, 1]]]
    if not len(pairs):
        return curves
    # Not near an end point the two curves share (a corner, met on a grid line).
    none = np.full((2, 3), np.nan)
    ends = np.array([none if c.closed else c.points[[0, -1]] for c in curves])
    a, b = owner[pairs[:, 0]], owner[pairs[:, 1]]
    d = np.linalg.norm(ends[a][:, :, None, :] - ends[b][:, None, :, :], axis=3)
    shared = np.min(np.where(np.isnan(d), np.inf, d), axis=(1, 2)) <= 1e-9 * max(gap, 1.0)
    near_end = np.linalg.norm(pts[pairs[:, 0]][:, None, :] - ends[a], axis=2).min(axis=1)
    close = ~shared | (near_end > CORNER_REACH * gap)
    if not close.any():
        return curves
    length = np.array([c.length for c in curves])
    a, b = a[close], b[close]
    drop = set(np.where(length[a] <= length[b], a, b).tolist())
    return [c for i, c in enumerate(curves) if i not in drop]


def _reaching(edges: np.ndarray, n: int, sharp: np.ndarray) -> np.ndarray:
    """The edges of the connected stretches that hold a sharp point."""
    if not len(edges):
        return edges
    g = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    _, label = connected_components(g, directed=False)
    hit = np.zeros(label.max() + 1, bool)
    hit[label[sharp]] = True
    return edges[hit[label[edges[:, 0]]]]


def _without_narrow_meetings(
    curves: list[FeatureCurve], radius: float, spacing: float
) -> list[FeatureCurve]:
    """The curves, less the shorter of any two that leave a common end point
    less than :data:`MIN_MEETING` degrees apart (balls could not separate
    them there: Mesh_3 and :func:`rdmesh.features.protect` shrink them
    without end). Curves on two planes meet where a grid line crosses the
    isosurface, at any angle."""
    for _ in range(MAX_PASSES):
        if not curves:
            return curves
        graph = build_graph(curves, radius)
        curves = graph.curves
        ends = graph.ends
        reach = np.array([min(TANGENT_REACH * spacing, 0.5 * c.length) for c in curves])
        # Unit directions leaving each end: (curve, side).
        out_dir = np.zeros((len(curves), 2, 3))
        for i, c in enumerate(curves):
            if c.closed:
                continue
            x = c.point_at(np.array([0.0, reach[i], c.length - reach[i], c.length]))
            out_dir[i, 0], out_dir[i, 1] = x[1] - x[0], x[2] - x[3]
        out_dir /= np.maximum(np.linalg.norm(out_dir, axis=2), 1e-300)[..., None]
        curve, side = np.nonzero(ends >= 0)
        corner = ends[curve, side]
        order = np.argsort(corner, kind="stable")
        curve, side, corner = curve[order], side[order], corner[order]
        a, b = _same_corner_pairs(corner)
        cos = np.einsum("ij,ij->i", out_dir[curve[a], side[a]], out_dir[curve[b], side[b]])
        narrow = (cos > np.cos(np.radians(MIN_MEETING))) & (curve[a] != curve[b])
        if not narrow.any():
            return curves
        length = np.array([c.length for c in curves])
        ca, cb = curve[a[narrow]], curve[b[narrow]]
        drop = np.unique(np.where(length[ca] <= length[cb], ca, cb))
        keep = np.setdiff1d(np.arange(len(curves)), drop)
        curves = [curves[i] for i in keep]
    return curves


def _same_corner_pairs(corner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All pairs ``(a, b)``, a < b, of entries of the sorted ``corner`` that are equal."""
    start = np.flatnonzero(np.r_[True, corner[1:] != corner[:-1]])
    size = np.diff(np.r_[start, len(corner)])
    a, b = [], []
    for s0, n in zip(start.tolist(), size.tolist(), strict=True):
        if n > 1:
            i, j = np.triu_indices(n, 1)
            a.append(s0 + i)
            b.append(s0 + j)
    if not a:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.concatenate(a), np.concatenate(b)


def _plane_branches(data, iso, axis, spacing, angle):
    """The sharp segments of the isocurves on the interior planes normal to
    ``axis``: points in index coordinates ``(m, 3)`` and segments ``(s, 2)``
    (rows of the points)."""
    v = np.moveaxis(data, axis, 0)
    t1, t2 = [k for k in range(3) if k != axis]
    P = v[1:-1]
    # Face cells away from the box's faces.
    A, B = P[:, 1:-2, 1:-2], P[:, 2:-1, 1:-2]
    C, E = P[:, 1:-2, 2:-1], P[:, 2:-1, 2:-1]
    inside = np.stack([A, B, C, E]) > iso
    cells = np.nonzero(inside.any(0) & ~inside.all(0))
    if not len(cells[0]):
        return np.zeros((0, 3)), np.zeros((0, 2), np.int64), np.zeros(0, bool)
    a, b, c, e = A[cells], B[cells], C[cells], E[cells]
    ends, owner = _branch_ends(a, b, c, e, iso)
    u, w = _dense(a[owner], b[owner], c[owner], e[owner], iso, ends)
    i, j, k = (x[owner][:, None] for x in cells)
    # One-sided normal derivatives: bilinear in the face of the differences.
    lo = v[:-2][:, 1:-1, 1:-1] - P[:, 1:-1, 1:-1]
    hi = v[2:][:, 1:-1, 1:-1] - P[:, 1:-1, 1:-1]

    def bil(D):
        return (D[i, j, k] * (1 - u) * (1 - w) + D[i, j + 1, k] * u * (1 - w)
                + D[i, j, k + 1] * (1 - u) * w + D[i, j + 1, k + 1] * u * w)  # fmt: skip

    ao, bo, co, eo = (x[owner][:, None] for x in (a, b, c, e))
    gu = ((bo - ao) * (1 - w) + (eo - co) * w) / spacing[t1]
    gw = ((co - ao) * (1 - u) + (eo - bo) * u) / spacing[t2]
    gl, gh = -bil(lo) / spacing[axis], bil(hi) / spacing[axis]
    tang = gu * gu + gw * gw
    cos = (gl * gh + tang) / np.sqrt(np.maximum((gl * gl + tang) * (gh * gh + tang), 1e-300))
    sharp = cos <= np.cos(np.radians(angle))
    # Stretches above the lower angle, grown from the sharp points.
    wide = cos <= np.cos(np.radians(min(angle, KINK_LOW)))
    seg = wide[:, 1:] | wide[:, :-1]
    br, st = np.nonzero(seg)
    m = u.shape[1]
    pts = np.empty((len(owner), m, 3))
    pts[..., axis], pts[..., t1], pts[..., t2] = i + 1, j + 1 + u, k + 1 + w
    rows = br * m + st
    seg = np.stack([rows, rows + 1], axis=1)
    # Only the points the segments use (the rest of the isocurves is mild).
    used, seg = np.unique(seg, return_inverse=True)
    return pts.reshape(-1, 3)[used], seg.reshape(-1, 2), sharp.reshape(-1)[used]


def _edge_t(p, q, iso):
    """Where the isovalue crosses each edge from p to q (NaN where it does not)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (iso - p) / (q - p)
    return np.where((p > iso) != (q > iso), t, np.nan)


def _branch_ends(a, b, c, e, iso):
    """The isocurve's branches in each face cell (corners a=(0,0), b=(1,0),
    c=(0,1), e=(1,1)): their end points ``(k, 2, 2)`` as ``(u, w)`` on the
    cell's edges, and the cell of each."""
    # Edges in cyclic order: w=0 (a-b), u=1 (b-e), w=1 (c-e), u=0 (a-c).
    tb, tr, tt, tl = _edge_t(a, b, iso), _edge_t(b, e, iso), _edge_t(c, e, iso), _edge_t(a, c, iso)
    uw = np.stack([
        np.stack([tb, np.zeros_like(tb)], -1), np.stack([np.ones_like(tr), tr], -1),
        np.stack([tt, np.ones_like(tt)], -1), np.stack([np.zeros_like(tl), tl], -1),
    ], axis=1)  # fmt: skip
    hit = ~np.isnan(uw[..., 0]) & ~np.isnan(uw[..., 1])
    count = hit.sum(1)
    two = np.flatnonzero(count == 2)
    first = np.argmax(hit[two], axis=1)
    second = 3 - np.argmax(hit[two][:, ::-1], axis=1)
    ends = [np.stack([uw[two, first], uw[two, second]], axis=1)]
    owner = [two]
    four = np.flatnonzero(count == 4)
    if len(four):
        # The asymptotic decider: the saddle's side says which corners the
        # branches cut off (the outside ones when the saddle is inside).
        a4, b4, c4, e4 = a[four], b[four], c[four], e[four]
        saddle = (a4 * e4 - b4 * c4) / (a4 - b4 - c4 + e4)
        a_cut = (a4 > iso) != (saddle > iso)  # a (and e) cut off, not b and c
        # Corner a lies between edges 3 and 0, b between 0 and 1, e between 1
        # and 2, c between 2 and 3; the cut corners are a and e, or b and c.
        p1 = np.where(a_cut[:, None], [[3, 0]], [[0, 1]])
        p2 = np.where(a_cut[:, None], [[1, 2]], [[2, 3]])
        for p in (p1, p2):
            ends.append(np.stack([uw[four, p[:, 0]], uw[four, p[:, 1]]], axis=1))
            owner.append(four)
    return np.concatenate(ends), np.concatenate(owner)


def _dense(a, b, c, e, iso, ends):
    """``PER_CELL`` points along each branch, ``(u, w)`` each ``(k, PER_CELL)``:
    spaced along the coordinate it spans most, the other solved exactly; the
    ends are the edge crossings themselves (shared with the next cell)."""
    s = np.linspace(0.0, 1.0, PER_CELL)[None, :]
    (u0, w0), (u1, w1) = ends[:, 0].T, ends[:, 1].T
    by_u = (np.abs(u1 - u0) >= np.abs(w1 - w0))[:, None]
    db, dc, dd = (b - a)[:, None], (c - a)[:, None], (a - b - c + e)[:, None]
    a0 = a[:, None]
    u = u0[:, None] + s * (u1 - u0)[:, None]
    w = w0[:, None] + s * (w1 - w0)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        w_of_u = (iso - a0 - db * u) / (dc + dd * u)
        u_of_w = (iso - a0 - dc * w) / (db + dd * w)
    u = np.where(by_u, u, u_of_w)
    w = np.where(by_u, w_of_u, w)
    u[:, 0], w[:, 0], u[:, -1], w[:, -1] = u0, w0, u1, w1
    return np.clip(u, 0.0, 1.0), np.clip(w, 0.0, 1.0)


def _projection(volume, axis: int):
    """Points near a kink curve on a plane normal to ``axis`` onto the curve:
    Newton on the interpolant within the plane."""

    def project(x: np.ndarray) -> np.ndarray:
        y = np.array(x, dtype=np.float64, copy=True).reshape(-1, 3)
        plane = volume.origin[axis] + volume.spacing[axis] * np.round(
            (y[:, axis] - volume.origin[axis]) / volume.spacing[axis]
        )
        y[:, axis] = plane
        for _ in range(NEWTON_STEPS):
            v, g = volume.value_gradients(y)
            g[:, axis] = 0.0
            step = (v - volume.isovalue) / np.maximum(np.einsum("ij,ij->i", g, g), 1e-300)
            y -= step[:, None] * g
            y[:, axis] = plane
        return y

    return project


__all__ = ["KINK_ANGLE", "KINK_SOURCE", "kink_curves"]
