"""Feature curves and corners: the 1-dimensional features a mesh must keep.

A :class:`FeatureGraph` holds curves (creases, boundary curves) as polylines in
order along each curve, split at corners (CGAL's rule: curves meet only at
their end points), and the corners. Each curve may carry an exact projection
onto the true curve (curves given by equations: a clip boundary, a volume's
box); without one the polyline is the curve.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from scipy.spatial import cKDTree

from .._vectors import row_norms

#: Consecutive polyline points closer than this (times R) are one point.
MERGE = 1e-9
#: Two curves (or two parts of one) closer than this (times R) meet.
MEET = 1e-7


class FeatureError(ValueError):
    """A feature curve is not usable: not an (m, 3) array of finite points,
    fewer than two distinct points, not on the surface, or crossing another
    curve (or itself) away from the curves' end points. The message names the
    curve (``features[i]``).

    ``where`` is the ``(3,)`` place, when the error has one (protection)."""

    def __init__(self, message: str, where: np.ndarray | None = None) -> None:
        super().__init__(message)
        self.where = None if where is None else np.asarray(where, dtype=np.float64)


@dataclass
class FeatureCurve:
    """One feature curve.

    Attributes
    ----------
    points : (m, 3) the polyline, in order along the curve; a closed curve
        does not repeat its first point.
    closed : bool
    source : str
        Where it came from: "given", "clip boundary", "volume box", "box edge",
        "mesh", "volume kink".
    project : callable, optional
        ``(k, 3) -> (k, 3)``: points near the curve onto the true curve (Newton
        on its equations). None: the polyline is the curve.
    label : str
        Names the curve in messages (``features[2]``).
    """

    points: np.ndarray
    closed: bool = False
    source: str = "given"
    project: Callable[[np.ndarray], np.ndarray] | None = None
    label: str = ""

    @cached_property
    def _ring(self) -> np.ndarray:
        """The polyline's points with the first repeated at the end when closed."""
        return np.concatenate([self.points, self.points[:1]]) if self.closed else self.points

    @cached_property
    def arc(self) -> np.ndarray:
        """Arc length at each point of the polyline (closed: with the closing point)."""
        ring = self._ring
        return np.r_[0.0, np.cumsum(row_norms(np.diff(ring, axis=0)))]

    @property
    def length(self) -> float:
        return float(self.arc[-1])

    def point_at(self, s: np.ndarray) -> np.ndarray:
        """Points of the polyline at arc positions ``s`` ``(k,)`` (wrapped when closed)."""
        s = np.asarray(s, dtype=float)
        if self.closed:
            s = np.mod(s, self.length)
        ring, arc = self._ring, self.arc
        j = np.clip(np.searchsorted(arc, s, side="right") - 1, 0, len(ring) - 2)
        ell = np.maximum(arc[j + 1] - arc[j], 1e-300)
        w = np.clip((s - arc[j]) / ell, 0.0, 1.0)
        return ring[j] + w[:, None] * (ring[j + 1] - ring[j])

    def on_curve(self, s: np.ndarray) -> np.ndarray:
        """Points of the true curve at arc positions ``s``: the polyline's points,
        projected when the curve has a projection."""
        x = self.point_at(s)
        return x if self.project is None else self.project(x)


@dataclass
class FeatureGraph:
    """Feature curves split at corners, and the corners.

    Attributes
    ----------
    curves : list of FeatureCurve
    corners : (c, 3) the corners: end points of open curves (shared ends are
        one corner) and isolated corners.
    ends : (len(curves), 2) int64 the corner at each end of each curve (-1 for
        a closed curve).
    """

    curves: list[FeatureCurve] = field(default_factory=list)
    corners: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    ends: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int64))

    def __len__(self) -> int:
        return len(self.curves)

    @property
    def empty(self) -> bool:
        return not self.curves and not len(self.corners)

    @property
    def ended(self) -> np.ndarray:
        """``(c,)`` bool: the corners that end a curve (the rest are isolated)."""
        return self.ended_by(np.ones(len(self.curves), bool))

    def ended_by(self, curves: np.ndarray) -> np.ndarray:
        """``(c,)`` bool: the corners that end one of the ``curves`` (a mask)."""
        out = np.zeros(len(self.corners), bool)
        ends = self.ends[np.asarray(curves, bool)] if len(self.curves) else self.ends
        out[ends[ends >= 0]] = True
        return out

    def merged(self, other: FeatureGraph, radius: float) -> FeatureGraph:
        """This graph and ``other`` as one (shared corners merged)."""
        if other.empty:
            return self
        if self.empty:
            return other
        return build_graph(self.curves + other.curves, radius, np.r_[self.corners, other.corners])


def as_polylines(features: object) -> list[np.ndarray]:
    """The user's ``features=`` as a list of ``(m, 3)`` float arrays, checked
    for shape and finiteness (FeatureError naming the polyline)."""
    if features is None:
        return []
    if isinstance(features, np.ndarray) and features.ndim == 2:
        raise FeatureError(
            "features must be a list of polylines, each an (m, 3) array; got one (m, 3) "
            "array: wrap it in a list"
        )
    if not isinstance(features, Sequence) and not isinstance(features, np.ndarray):
        raise FeatureError(
            f"features must be a list of (m, 3) arrays, got {type(features).__name__}"
        )
    out = []
    for i, p in enumerate(features):
        try:
            a = np.array(p, dtype=np.float64)
        except (TypeError, ValueError):
            raise FeatureError(f"features[{i}] is not an array of numbers") from None
        if a.ndim != 2 or a.shape[1] != 3:
            raise FeatureError(f"features[{i}] must have shape (m, 3), got {a.shape}")
        if not np.all(np.isfinite(a)):
            j = int(np.argmax(~np.isfinite(a).all(axis=1)))
            raise FeatureError(f"features[{i}] has a non-finite point (point {j}: {a[j]})")
        if len(a) < 2:
            raise FeatureError(f"features[{i}] has {len(a)} point; a curve needs at least two")
        out.append(a)
    return out


def curve_of_polyline(points: np.ndarray, radius: float, label: str, source: str) -> FeatureCurve:
    """A curve from a checked polyline: repeated consecutive points merged, and
    closed when its last point repeats its first."""
    tol = MERGE * radius
    step = row_norms(np.diff(points, axis=0))
    keep = np.r_[True, step > tol]
    p = points[keep]
    closed = len(p) >= 3 and float(row_norms(p[-1:] - p[:1])[0]) <= tol
    if closed:
        p = p[:-1]
    if len(p) < 2:
        raise FeatureError(f"{label} has fewer than two distinct points")
    if closed and len(p) < 3:
        raise FeatureError(f"{label} is a closed loop of fewer than three distinct points")
    return FeatureCurve(p, closed=closed, source=source, label=label)


def given_curves(polylines: list[np.ndarray], radius: float) -> list[FeatureCurve]:
    """The user's polylines (checked by :func:`as_polylines`) as curves."""
    return [
        curve_of_polyline(p, radius, f"features[{i}]", "given") for i, p in enumerate(polylines)
    ]


def build_graph(
    curves: list[FeatureCurve], radius: float, extra_corners: np.ndarray | None = None
) -> FeatureGraph:
    """Curves split where one's end point lies on another's interior, shared
    end points merged into corners, and crossings in the interiors refused
    (FeatureError naming both curves)."""
    tol = MEET * radius
    curves = _split_at_ends(curves, tol)
    _refuse_crossings(curves, tol)
    ends_xyz = [c.points[[0, -1]] for c in curves if not c.closed]
    pts = [np.zeros((0, 3))] + ends_xyz
    if extra_corners is not None and len(extra_corners):
        pts.append(np.asarray(extra_corners, float).reshape(-1, 3))
    allp = np.concatenate(pts)
    corners, label = _cluster(allp, tol)
    ends = np.full((len(curves), 2), -1, np.int64)
    k = 0
    for i, c in enumerate(curves):
        if not c.closed:
            ends[i] = label[k : k + 2]
            k += 2
    # A corner's position is the end point of its first curve (exact there).
    return FeatureGraph(curves, corners, ends)


def _cluster(points: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Points within ``tol`` of each other as one: (representatives, label per point)."""
    if len(points) == 0:
        return np.zeros((0, 3)), np.zeros(0, np.int64)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    pairs = np.array(sorted(cKDTree(points).query_pairs(tol)), dtype=np.int64).reshape(-1, 2)
    n = len(points)
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, lab = connected_components(g, directed=False)
    first = np.full(lab.max() + 1, n)
    np.minimum.at(first, lab, np.arange(n))
    # Renumbered in order of first appearance, so the result is deterministic.
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return points[first[order]], rank[lab]


def _segments(curves: list[FeatureCurve]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every polyline segment: (a (S, 3), b (S, 3), curve index (S,))."""
    a, b, owner = [], [], []
    for i, c in enumerate(curves):
        ring = c._ring
        a.append(ring[:-1])
        b.append(ring[1:])
        owner.append(np.full(len(ring) - 1, i))
    return np.concatenate(a), np.concatenate(b), np.concatenate(owner)


def _point_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance from points to segments (row-wise) and the segment parameter."""
    d = b - a
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    t = np.clip(np.einsum("ij,ij->i", p - a, d) / dd, 0.0, 1.0)
    return row_norms(a + t[:, None] * d - p), t


def _pieces(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Segments cut into pieces no longer than ``h``: (piece midpoints, the
    segment of each piece, ``h``).  ``h`` is twice the median length, or more
    so that there are at most five times as many pieces as segments: one long
    segment (a box edge) then does not widen every proximity query."""
    length = row_norms(b - a)
    h = max(2.0 * float(np.median(length)), float(length.sum()) / (4.0 * len(length)), 1e-300)
    n = np.maximum(np.ceil(length / h).astype(np.int64), 1)
    seg = np.repeat(np.arange(len(a)), n)
    first = np.cumsum(n) - n
    t = (np.arange(len(seg)) - first[seg] + 0.5) / n[seg]
    return a[seg] + t[:, None] * (b - a)[seg], seg, h


def _near_points(points: np.ndarray, a: np.ndarray, b: np.ndarray, tol: float):
    """Candidate (point, segment) pairs: every segment within ``tol`` of a
    point is among them (unique pairs, as two arrays)."""
    mid, seg, h = _pieces(a, b)
    hits = cKDTree(mid).query_ball_point(points, 0.5 * h + tol)
    k = np.repeat(np.arange(len(points)), [len(x) for x in hits])
    s = seg[np.concatenate([np.asarray(x, np.int64) for x in hits])] if len(k) else k
    pairs = np.unique(np.stack([k, s], axis=1), axis=0) if len(k) else np.zeros((0, 2), np.int64)
    return pairs[:, 0], pairs[:, 1]


def _near_segments(a: np.ndarray, b: np.ndarray, tol: float) -> np.ndarray:
    """Candidate segment pairs (i < j): every pair within ``tol`` is among them."""
    mid, seg, h = _pieces(a, b)
    p = cKDTree(mid).query_pairs(h + tol, output_type="ndarray")
    p = np.sort(seg[p], axis=1)
    p = p[p[:, 0] != p[:, 1]]
    return np.unique(p, axis=0) if len(p) else np.zeros((0, 2), np.int64)


def _split_at_ends(curves: list[FeatureCurve], tol: float) -> list[FeatureCurve]:
    """Each open curve's end points that lie on another curve's interior
    split that curve there (a T-junction becomes a corner)."""
    open_ = [i for i, c in enumerate(curves) if not c.closed]
    if not open_ or len(curves) < 2:
        return curves
    e = np.concatenate([curves[i].points[[0, -1]] for i in open_])
    a, b, owner = _segments(curves)
    index = np.concatenate([np.arange(len(c._ring) - 1) for c in curves])
    half = 0.5 * row_norms(b - a)
    k, seg = _near_points(e, a, b, tol)
    d, t = _point_segment(e[k], a[seg], b[seg])
    near = d <= tol
    k, seg, t = k[near], seg[near], t[near]
    # Not where the point is this curve's own end point (or a vertex shared
    # with the next segment, found on that segment too).
    n_seg = np.array([len(c._ring) - 1 for c in curves])[owner[seg]]
    closed = np.array([c.closed for c in curves])[owner[seg]]
    ell = 2 * half[seg]
    at_start, at_end = t * ell <= tol, (1 - t) * ell <= tol
    own_end = ~closed & (((index[seg] == 0) & at_start) | ((index[seg] == n_seg - 1) & at_end))
    inner_vertex_twice = at_start & ((index[seg] > 0) | closed)
    keep = ~own_end & ~inner_vertex_twice
    k, seg, t = k[keep], seg[keep], t[keep]
    if len(seg) == 0:
        return curves
    out = []
    for i, c in enumerate(curves):
        mine = owner[seg] == i
        if not mine.any():
            out.append(c)
            continue
        cuts = list(zip(index[seg[mine]].tolist(), t[mine].tolist(), e[k[mine]], strict=True))
        out.extend(_cut(c, cuts, tol))
    return out


def _cut(c: FeatureCurve, cuts: list, tol: float) -> list[FeatureCurve]:
    """Curve ``c`` cut at points (segment j, parameter t, point)."""
    cuts = sorted(cuts, key=lambda x: (x[0], x[1]))
    ring = c._ring
    pieces, cur = [], [ring[0]]
    for j in range(len(ring) - 1):
        here = [x for x in cuts if x[0] == j]
        for _, _, p in here:
            if row_norms((p - cur[-1])[None])[0] > tol:
                cur.append(p)
            pieces.append(np.array(cur))
            cur = [p]
        if row_norms((ring[j + 1] - cur[-1])[None])[0] > tol:
            cur.append(ring[j + 1])
    pieces.append(np.array(cur))
    if c.closed and len(pieces) > 1:
        # The piece through the closing point joins the first and last.
        pieces = [np.concatenate([pieces[-1], pieces[0][1:]])] + pieces[1:-1]
    return [FeatureCurve(p, False, c.source, c.project, c.label) for p in pieces if len(p) >= 2]


def _refuse_crossings(curves: list[FeatureCurve], tol: float) -> None:
    """FeatureError when two segments that are not neighbours along one curve
    come within ``tol`` of each other away from the curves' end points."""
    a, b, owner = _segments(curves)
    if len(a) < 2:
        return
    index = np.concatenate([np.arange(len(c._ring) - 1) for c in curves])
    nseg = np.array([len(c._ring) - 1 for c in curves])
    pairs = _near_segments(a, b, tol)
    if len(pairs) == 0:
        return
    i, j = pairs[:, 0], pairs[:, 1]
    same = owner[i] == owner[j]
    gap = np.abs(index[i] - index[j])
    closed = np.array([c.closed for c in curves])[owner[i]]
    wrap = closed & (gap == nseg[owner[i]] - 1)
    pairs = pairs[~(same & ((gap <= 1) | wrap))]
    if len(pairs) == 0:
        return
    d = _segment_distance(a[pairs[:, 0]], b[pairs[:, 0]], a[pairs[:, 1]], b[pairs[:, 1]])
    close = d <= tol
    if not close.any():
        return
    # Touching only at shared end points of open curves is allowed.
    ends = np.concatenate(
        [c.points[[0, -1]] for c in curves if not c.closed] or [np.zeros((0, 3))]
    )
    for k in np.flatnonzero(close):
        s, t = pairs[k]
        x = _closest_point(a[s], b[s], a[t], b[t])
        if len(ends) and row_norms(ends - x).min() <= 10 * tol:
            continue
        ci, cj = curves[owner[s]], curves[owner[t]]
        what = (
            f"{ci.label or 'a curve'} crosses itself"
            if owner[s] == owner[t]
            else f"{ci.label or 'a curve'} and {cj.label or 'another curve'} cross"
        )
        raise FeatureError(
            f"{what} at {np.round(x, 9).tolist()}, away from their end points: feature "
            "curves may meet only at their end points (split them there)"
        )


def _segment_distance(p1, q1, p2, q2) -> np.ndarray:
    """Distance between segments [p1, q1] and [p2, q2], row-wise (clamped
    closest points; exact enough for a crossing test)."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a = np.einsum("ij,ij->i", d1, d1)
    e = np.einsum("ij,ij->i", d2, d2)
    f = np.einsum("ij,ij->i", d2, r)
    c = np.einsum("ij,ij->i", d1, r)
    b = np.einsum("ij,ij->i", d1, d2)
    den = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(den > 1e-300 * (a * e + 1e-300), np.clip((b * f - c * e) / den, 0, 1), 0.0)
        t = np.where(e > 1e-300, (b * s + f) / e, 0.0)
    t = np.clip(t, 0.0, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(a > 1e-300, np.clip((b * t - c) / a, 0.0, 1.0), 0.0)
    return row_norms(p1 + s[:, None] * d1 - (p2 + t[:, None] * d2))


def _closest_point(p1, q1, p2, q2) -> np.ndarray:
    """A point of segment [p1, q1] nearest segment [p2, q2]."""
    ts = np.linspace(0.0, 1.0, 65)
    pts = p1 + ts[:, None] * (q1 - p1)
    d, _ = _point_segment(pts, np.broadcast_to(p2, pts.shape), np.broadcast_to(q2, pts.shape))
    return pts[int(np.argmin(d))]
