"""Protecting balls on the feature curves (Cheng-Dey-Ramos; CGAL Mesh_3's
``Protect_edges_sizing_field``; ../shared/design/creases.md 2.3).

Every corner gets a ball, then every curve a chain of balls centred on the
curve, consecutive balls overlapping, no three meeting, balls of different
curves (and far parts of one) disjoint. As weighted points of the regular
triangulation they keep each pair of consecutive centres a triangulation
edge, and refinement never inserts a point inside a ball (a surface ball's
centre has positive power to every vertex).

Sizes. The spacing ``h`` of the centres along a curve is at most:

* ``edge_size`` (CGAL's name: the largest length of a mesh edge along a curve);
* half the curve's radius of curvature (so that a chord of two steps stays
  longer than two radii), ``sqrt(8 d / kappa)`` for a distance bound d, and
  ``4 d / t`` next to a polyline vertex that turns by ``t`` radians
  (a chord's sagitta);
* the distance to other curves (or to far parts of the same curve) / 2.1, as
  Mesh_3's ``refine_balls`` shrinks balls;
* half the distance to other sheets of the surface, sampled: surface points
  whose tangent plane does not pass near the curve point (so a ball cannot
  reach across a thin part);
* for a corner, a third of the distance to the nearest other corner.

``h`` grows by at most :data:`GROWTH` per unit of arc (so consecutive spacings
differ by a bounded ratio), from at most twice an end corner's radius at the
corner (Mesh_3 grades a curve's balls between its end balls' sizes). Corner
balls have radius at most half the spacing there; an open curve's first ball
sits a quarter spacing beyond the corner ball. A ball's radius is 0.9 times
its smaller spacing to a neighbour and at most 0.9 h at its centre. The
invariants are then checked exactly on the balls and repaired as Mesh_3's
``refine_balls`` and ``check_and_repopulate_edges`` do: balls that meet but are not consecutive
shrink to their distance / 2.1, and new balls fill a stretch that consecutive
balls no longer cover (one ball where the stretch is shorter than the
spacing). Consecutive balls that overlap by less than :data:`LENS` are mended
instead: the smaller grows, or one moves along the curve towards the other (a
ball between them would hold both centres). At most :data:`MAX_LOOPS` times
(CGAL caps its loop at 29, with a warning only), after which
:class:`FeatureError` is raised.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from .._vectors import row_norms
from .graph import FeatureError, FeatureGraph

log = logging.getLogger("rdmesh")

#: Ball radius over the smaller distance to a neighbouring centre (Mesh_3: 0.9).
RADIUS_FACTOR = 0.9
#: Balls of different curves: spacing at most this fraction of their distance.
CURVE_GAP = 1 / 2.1
#: Spacing at most this fraction of the radius of curvature.
CURVATURE = 0.5
#: Spacing at most this fraction of the distance to another sheet.
SHEET_GAP = 0.5
#: Corner balls: radius at most this fraction of the spacing there, so that
#: the first ball out, half a spacing beyond the corner ball, is at most a
#: spacing from the corner.
CORNER_FACTOR = 0.5
#: Corner balls: radius at most this fraction of the distance to another corner.
CORNER_GAP = 1 / 3
#: Curve points within this fraction of a corner ball's radius are the corner's.
CORNER_CORE = 0.5
#: Largest growth of the spacing per unit of arc length.
GROWTH = 0.4
#: Dense points of the curves per spacing.
DENSITY = 8
#: Spacing factor where a mesh failed its feature check.
SHRINK = 0.6
#: Repair rounds at most (CGAL: 29).
MAX_LOOPS = 40
#: Sheet samples within this fraction of the spacing of a curve point are on it.
SAME_POINT = 1e-6
#: Smallest spacing, times R: protection below it is refused.
MIN_SIZE = 1e-6
#: Protection needing more than this many times the balls that the curves'
#: length asks for at the largest spacing is refused: curves or corners that
#: close together (a hair-thin step along an edge) are no feature of this size.
MAX_EXCESS = 1000

Sizing = Callable[[np.ndarray], np.ndarray]


@dataclass
class Balls:
    """Protecting balls of a feature graph.

    Attributes
    ----------
    centres : (b, 3) on the curves (corners first).
    radii : (b,)
    curve : (b,) int64 the curve of each ball (-1 for a corner).
    corner : (b,) int64 the corner of each corner ball (-1 otherwise).
    pairs : (e, 2) int64 consecutive balls along a curve (indices into the balls).
    pair_curve : (e,) int64 the curve of each pair.
    chains : list of (k,) int64 each curve's balls in order, end corners included.
    boundary : (len(curves),) bool curves that bound the mesh (one facet per edge).
    loops : number of repair loops that ran.
    """

    centres: np.ndarray
    radii: np.ndarray
    curve: np.ndarray
    corner: np.ndarray
    pairs: np.ndarray
    pair_curve: np.ndarray
    chains: list[np.ndarray] = field(default_factory=list)
    boundary: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    loops: int = 0
    #: (b,) int64 each ball's position in its curve's own balls (-1 for a corner).
    index: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))

    def __len__(self) -> int:
        return len(self.centres)

    @property
    def weights(self) -> np.ndarray:
        return self.radii**2

    def inside(self, points: np.ndarray, factor: float = 1.0) -> np.ndarray:
        """Which ``(k, 3)`` points lie inside a ball (radius times ``factor``)."""
        if len(self) == 0 or len(points) == 0:
            return np.zeros(len(points), bool)
        tree = cKDTree(self.centres)
        reach = factor * float(self.radii.max())
        d, j = tree.query(points, k=min(8, len(self)), distance_upper_bound=reach)
        d = d.reshape(len(points), -1)
        j = j.reshape(len(points), -1)
        r = np.r_[self.radii, 0.0][np.minimum(j, len(self))]
        return (d < factor * r).any(axis=1)


@dataclass
class _Dense:
    """One curve sampled densely: arc positions and points on the polyline."""

    s: np.ndarray
    x: np.ndarray
    kappa: np.ndarray  # curvature estimate at each point
    turn: np.ndarray  # the larger turning angle (radians) at its segment's two vertices


def protect(
    graph: FeatureGraph,
    edge_size: Sizing,
    radius: float,
    sheets: tuple[np.ndarray, np.ndarray] | None = None,
    boundary_sources: tuple[str, ...] = ("clip boundary", "hole rim"),
    distance: float | None = None,
    shrink: list[tuple[np.ndarray, np.ndarray]] | None = None,
) -> Balls:
    """Place protecting balls on every corner and curve of ``graph``.

    Parameters
    ----------
    graph : FeatureGraph
    edge_size : callable
        ``(k, 3)`` points to ``k`` largest spacings of the centres.
    radius : the bounding radius R (tolerances).
    sheets : ((s, 3) points, (s, 3) unit normals), optional
        Samples of the surface, to keep balls off other sheets (sampled).
    boundary_sources : the curve sources that bound the mesh.
    distance : float, optional
        The distance bound: a chord between consecutive centres strays at
        most this far from the curve (``8 d / kappa >= h^2``, from the
        curvature estimate).
    shrink : list of ((k, 3) points, (k,) radii), optional
        Places where an earlier mesh failed its feature check: the spacing
        within each radius of each point is multiplied by :data:`SHRINK`, once
        per entry (DelPSC's repair).

    Returns
    -------
    Balls

    Raises
    ------
    FeatureError
        When the invariants cannot be met above the smallest spacing (curves
        or corners closer than ``MIN_SIZE x R``), naming the place.
    """
    curves = graph.curves
    floor = MIN_SIZE * radius
    h_max = float(
        np.max(
            edge_size(
                np.concatenate([c.points for c in curves] or [graph.corners, np.zeros((1, 3))])
            )
        )
    )
    dense = [_densify(c, h_max) for c in curves]
    if sheets is not None and len(sheets[0]):
        # One tree for every query (one per curve and the corners).
        sheets = (*sheets, cKDTree(sheets[0]))
    state = _place(graph, dense, edge_size, sheets, distance, shrink or [], floor)
    boundary = np.array([c.source in boundary_sources for c in curves], bool)
    length = sum(float(row_norms(np.diff(c.points, axis=0)).sum()) for c in curves)
    for loop in range(MAX_LOOPS):
        balls = _assemble(graph, state)
        balls.boundary, balls.loops = boundary, loop
        _check_count(balls, MAX_EXCESS * max(length / h_max, 1.0))
        if not _repair(balls, state, graph):
            return balls
        if state.smallest() < floor:
            i = int(np.argmin(balls.radii))
            raise FeatureError(
                f"cannot protect the feature curves near {np.round(balls.centres[i], 9).tolist()}:"
                f" the balls there would be smaller than {floor:.3g} (curves or corners too "
                "close together, or meeting at too small an angle)",
                where=balls.centres[i],
            )
    raise FeatureError(
        f"protecting balls still break an invariant after {MAX_LOOPS} loops (curves or "
        "corners too close together, or meeting at too small an angle)",
        where=balls.centres[int(np.argmin(balls.radii))],
    )


def _check_count(balls: Balls, most: float) -> None:
    """Refuse protection by more than ``most`` balls (:data:`MAX_EXCESS`)."""
    if len(balls.radii) > most:
        i = int(np.argmin(balls.radii))
        raise FeatureError(
            f"cannot protect the feature curves: {len(balls.radii)} balls (radii down to "
            f"{balls.radii[i]:.3g}, near {np.round(balls.centres[i], 9).tolist()}) are more "
            f"than {MAX_EXCESS} times what the curves' length asks for at the size bound "
            "(curves or corners far closer together than the size bound)",
            where=balls.centres[i],
        )


@dataclass
class _State:
    """Balls being placed: per curve, the arc positions, centres and radii of
    its own balls (not its end corners), and the corners' radii."""

    s: list[np.ndarray]
    x: list[np.ndarray]
    r: list[np.ndarray]
    r_corner: np.ndarray

    def smallest(self) -> float:
        vals = [self.r_corner] + self.r
        return min((float(v.min()) for v in vals if len(v)), default=np.inf)


def _assemble(graph: FeatureGraph, st: _State) -> Balls:
    """The balls of a state: corners first, then each curve's in order."""
    n_c = len(graph.corners)
    centres, radii, curve_of, corner_of, index = [graph.corners], [st.r_corner], [], [], []
    curve_of.append(np.full(n_c, -1))
    corner_of.append(np.arange(n_c))
    index.append(np.full(n_c, -1))
    pairs, pair_curve, chains = [], [], []
    next_id = n_c
    for i, c in enumerate(graph.curves):
        m = len(st.s[i])
        ids = np.arange(next_id, next_id + m)
        next_id += m
        centres.append(st.x[i])
        radii.append(st.r[i])
        curve_of.append(np.full(m, i))
        corner_of.append(np.full(m, -1))
        index.append(np.arange(m))
        if c.closed:
            chain = np.r_[ids, ids[:1]]
        else:
            a, b = graph.ends[i]
            chain = np.r_[a, ids, b]
        pairs.append(np.c_[chain[:-1], chain[1:]])
        pair_curve.append(np.full(len(chain) - 1, i))
        chains.append(chain)
    balls = Balls(
        centres=np.concatenate(centres),
        radii=np.concatenate(radii),
        curve=np.concatenate(curve_of).astype(np.int64),
        corner=np.concatenate(corner_of).astype(np.int64),
        pairs=np.concatenate(pairs).astype(np.int64) if pairs else np.zeros((0, 2), np.int64),
        pair_curve=np.concatenate(pair_curve).astype(np.int64) if pairs else np.zeros(0, np.int64),
        chains=chains,
    )
    balls.index = np.concatenate(index).astype(np.int64)
    return balls


def _repair(balls: Balls, st: _State, graph: FeatureGraph) -> bool:
    """One round of Mesh_3's ``refine_balls`` and ``check_and_repopulate_edges``
    on the state; returns whether anything was broken.

    Balls that meet but are not consecutive shrink to their distance / 2.1; a
    ball holding its neighbour's centre shrinks to 0.9 times their distance;
    consecutive balls that no longer overlap get new balls between them,
    spaced by the smaller radius."""
    c, r = balls.centres, balls.radii.copy()
    broken = False
    meet = _meeting(balls)
    if len(meet):
        d = row_norms(c[meet[:, 0]] - c[meet[:, 1]])
        np.minimum.at(r, meet[:, 0], CURVE_GAP * d)
        np.minimum.at(r, meet[:, 1], CURVE_GAP * d)
        broken = True
    p = balls.pairs
    if len(p):
        d = row_norms(c[p[:, 0]] - c[p[:, 1]])
        big = np.where(r[p[:, 0]] >= r[p[:, 1]], p[:, 0], p[:, 1])
        inside = d <= r[big] * (1.0 + 1e-9)
        if inside.any():
            np.minimum.at(r, big[inside], RADIUS_FACTOR * d[inside])
            broken = True
    gap = np.zeros(len(p), bool)
    if len(p):
        ra, rb = r[p[:, 0]], r[p[:, 1]]
        gap = d >= ra + rb - LENS * np.minimum(ra, rb)
        # Consecutive balls that overlap, but by less than the lens: a ball
        # between them would have its centre in both (and the larger would
        # shrink again), so one of them grows or moves closer instead.
        thin = gap & (d < ra + rb)
        if thin.any():
            gap &= ~_pull(balls, st, graph, np.flatnonzero(thin), r, d)
            broken = True
    _write_radii(balls, st, r)
    if gap.any():
        broken = True
        _split(balls, st, graph, np.flatnonzero(gap), r)
    return broken


#: Consecutive balls must overlap by this fraction of the smaller radius.
LENS = 0.25
#: A ball moved to make the lens overlaps its neighbour this much more.
PULL_LENS = 1.02
#: New balls per stretch and round at most (the next round fills what is left).
MAX_SPLIT = 1000


def _write_radii(balls: Balls, st: _State, r: np.ndarray) -> None:
    corner = balls.corner >= 0
    st.r_corner = r[corner][np.argsort(balls.corner[corner])]
    for i in range(len(st.r)):
        mine = balls.curve == i
        st.r[i] = r[mine][np.argsort(balls.index[mine])]


def _pull(
    balls: Balls,
    st: _State,
    graph: FeatureGraph,
    which: np.ndarray,
    r: np.ndarray,
    d: np.ndarray,
) -> np.ndarray:
    """Mend consecutive pairs ``which`` that overlap by less than the lens
    without a ball between them (its centre would lie in both): the smaller
    ball grows, if it then meets no other ball; else one that is not a corner
    moves towards the other, if it keeps the lens with its other neighbour.
    Grown radii are written to ``r``, moved balls to ``st``. Returns which
    pairs (over every pair) were mended; the rest are split."""
    mended = np.zeros(len(balls.pairs), bool)
    touched: set[int] = set()
    tree = cKDTree(balls.centres)
    # A grown ball stays under this (d - r_big < r_small for a thin pair).
    reach = float(r.max()) * PULL_LENS / (1.0 - LENS)
    for k in which:
        a, b = (int(x) for x in balls.pairs[k])
        if a in touched or b in touched:
            continue
        small, big = (a, b) if r[a] <= r[b] else (b, a)
        grown = PULL_LENS * (d[k] - r[big]) / (1.0 - LENS)
        near = _neighbours(balls, small)
        if _fits(balls, tree, reach, small, grown, r, near):
            r[small] = grown
            touched.update((a, b))
            mended[k] = True
            continue
        for m, other in ((small, big), (big, small)):
            if balls.corner[m] >= 0:
                continue
            if _move_towards(balls, st, graph, m, other, r, float(d[k])):
                touched.update((a, b))
                mended[k] = True
                break
    return mended


def _neighbours(balls: Balls, ball: int) -> tuple[int, ...]:
    """The balls consecutive to ``ball`` on its curve's chain (a corner: on every
    curve ending at it)."""
    p = balls.pairs
    return tuple(int(x) for x in np.r_[p[p[:, 0] == ball, 1], p[p[:, 1] == ball, 0]])


def _fits(balls, tree, reach, ball, radius, r, near) -> bool:
    """Whether ``ball`` with ``radius`` holds no neighbour's centre and meets no
    ball but its neighbours."""
    c = balls.centres[ball]
    for j in tree.query_ball_point(c, radius + reach):
        if j == ball:
            continue
        dist = float(np.linalg.norm(balls.centres[j] - c))
        if j in near:
            if dist <= radius * (1.0 + 1e-9):
                return False
        elif dist <= (radius + r[j]) * (1.0 + 1e-9):
            return False
    return True


def _move_towards(balls, st, graph, m: int, other: int, r, d: float) -> bool:
    """Move curve ball ``m`` along its curve towards its neighbour ``other``
    (``d`` apart) so that they overlap by the lens, if ``m`` then keeps the
    lens with its other neighbour without holding its centre; returns whether
    it moved. (A ball it then meets is found by the next round's check.)"""
    curve, j = int(balls.curve[m]), int(balls.index[m])
    c = graph.curves[curve]
    want = r[other] + (1.0 - LENS) * r[m] / PULL_LENS
    if want <= max(r[m], r[other]):
        return False  # it would hold the other's centre
    # Its place on the chain: an open curve's chain starts with its corner; a
    # closed one's repeats its first ball last.
    chain = balls.chains[curve]
    pos = j if c.closed else j + 1
    forward = chain[pos + 1] == other
    behind = chain[pos - 1 if pos > 0 else -2] if forward else chain[pos + 1]
    s_new = st.s[curve][j] + (d - want if forward else want - d)
    if c.closed:
        s_new = float(np.mod(s_new, c.length))
    elif not 0.0 < s_new < c.length:
        return False
    x = c.on_curve(np.array([s_new]))[0]
    gap = float(np.linalg.norm(x - balls.centres[behind]))
    if gap >= r[m] + r[behind] - LENS * min(r[m], r[behind]) or gap <= max(r[m], r[behind]):
        return False
    st.s[curve][j] = s_new
    st.x[curve][j] = x
    return True


def _split(
    balls: Balls, st: _State, graph: FeatureGraph, which: np.ndarray, r: np.ndarray
) -> None:
    """New balls between the consecutive pairs ``which`` (indices into pairs)."""
    add: dict[int, list[tuple[np.ndarray, np.ndarray]]] = {}
    for k in which:
        i = int(balls.pair_curve[k])
        c = graph.curves[i]
        a, b = balls.pairs[k]
        sa = _arc_of(balls, st, graph, a, i, start=True)
        sb = _arc_of(balls, st, graph, b, i, start=False)
        if c.closed and sb <= sa:
            sb += c.length
        # New centres in the stretch neither ball covers, a quarter spacing
        # inside it, spaced at most the smaller radius.
        step = min(r[a], r[b])
        if not step > 0.0:
            continue  # a ball shrunk to nothing: protect() refuses it (the floor)
        ea, eb = sa + r[a], sb - r[b]
        lo, hi = ea + 0.25 * step, eb - 0.25 * step
        if hi - lo < step:
            # One ball covers it: two, at its ends, would hold each other's centre.
            mid = 0.5 * (ea + eb)
            if not sa < mid < sb:
                # The balls overlap along the arc but not in space (the curve
                # bends, or its points are projected onto an exact curve).
                mid = sa + (sb - sa) * r[a] / (r[a] + r[b])
            s_new = np.array([mid])
            r_new = np.array([RADIUS_FACTOR * step])
        else:
            n = min(int(np.ceil((hi - lo) / step)), MAX_SPLIT)
            s_new = lo + (hi - lo) * np.arange(n + 1) / max(n, 1)
            r_new = np.full(
                len(s_new), RADIUS_FACTOR * min(step, (hi - lo) / max(n, 1) + 0.5 * step)
            )
        if c.closed:
            s_new = np.mod(s_new, c.length)
        add.setdefault(i, []).append((s_new, r_new))
    for i, parts in add.items():
        c = graph.curves[i]
        s_all = np.concatenate([st.s[i]] + [q[0] for q in parts])
        r_all = np.concatenate([st.r[i]] + [q[1] for q in parts])
        order = np.argsort(s_all, kind="stable")
        st.s[i], st.r[i] = s_all[order], r_all[order]
        st.x[i] = c.on_curve(st.s[i])


def _arc_of(balls, st, graph, ball: int, curve: int, start: bool) -> float:
    """The arc position on ``curve`` of a ball of its chain (a corner: an end)."""
    if balls.corner[ball] >= 0:
        return 0.0 if start else graph.curves[curve].length
    return float(st.s[curve][balls.index[ball]])


def _within(points: np.ndarray, centres: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """Which points lie within ``reach`` (per centre) of some centre."""
    if len(points) == 0 or len(centres) == 0:
        return np.zeros(len(points), bool)
    k = min(16, len(centres))
    d, j = cKDTree(centres).query(points, k=k, distance_upper_bound=float(reach.max()))
    d, j = d.reshape(len(points), -1), j.reshape(len(points), -1)
    r = np.r_[reach, 0.0][np.minimum(j, len(centres))]
    return (d < r).any(axis=1)


def _densify(curve, h: float) -> _Dense:
    """Points along a curve's polyline at most ``h / DENSITY`` apart (polyline
    vertices kept), with the discrete curvature at each."""
    arc = curve.arc
    seg = np.diff(arc)
    per = np.maximum(np.ceil(seg * DENSITY / max(h, 1e-300)), 1).astype(np.int64)
    start = np.repeat(arc[:-1], per)
    k = np.arange(per.sum()) - np.repeat(np.cumsum(per) - per, per)
    s = start + np.repeat(seg / per, per) * k
    if not curve.closed:
        s = np.r_[s, arc[-1]]
    x = curve.point_at(s)
    # Curvature at the polyline's vertices: turning angle over the mean of the
    # adjacent segments; spread to each segment's points as the larger of its ends.
    ring = curve.points
    n = len(ring)
    if curve.closed:
        prv, nxt = np.roll(ring, 1, axis=0), np.roll(ring, -1, axis=0)
    else:
        prv, nxt = np.r_[ring[:1], ring[:-1]], np.r_[ring[1:], ring[-1:]]
    u, v = ring - prv, nxt - ring
    lu, lv = row_norms(u), row_norms(v)
    cos = np.einsum("ij,ij->i", u, v) / np.maximum(lu * lv, 1e-300)
    angle = np.arccos(np.clip(cos, -1.0, 1.0))
    k_v = np.where((lu > 0) & (lv > 0), angle / np.maximum(0.5 * (lu + lv), 1e-300), 0.0)
    if not curve.closed:
        k_v[[0, -1]] = 0.0
    k_next = np.roll(k_v, -1) if curve.closed else np.r_[k_v[1:], 0.0]
    k_seg = np.maximum(k_v, k_next)[: len(seg)] if n > 1 else np.zeros(len(seg))
    kappa = np.repeat(k_seg, per)
    if not curve.closed:
        angle[[0, -1]] = 0.0
    a_next = np.roll(angle, -1) if curve.closed else np.r_[angle[1:], 0.0]
    turn = np.repeat(np.maximum(angle, a_next)[: len(seg)] if n > 1 else np.zeros(len(seg)), per)
    if not curve.closed:
        # The end's spacing bounds its corner ball: the last segment's turn.
        kappa, turn = np.r_[kappa, k_v[-1]], np.r_[turn, turn[-1:] if len(turn) else 0.0]
    return _Dense(s, x, kappa, turn)


def _lipschitz(h: np.ndarray, s: np.ndarray, closed: bool, length: float) -> np.ndarray:
    """The largest function below ``h`` growing at most GROWTH per unit arc."""
    if closed:
        # Three copies: the wrap-around is seen from both sides.
        s3 = np.r_[s - length, s, s + length]
        h3 = np.r_[h, h, h]
        out = _lipschitz(h3, s3, False, 0.0)
        return out[len(s) : 2 * len(s)]
    g = GROWTH
    fwd = g * s + np.minimum.accumulate(h - g * s)
    bwd = -g * s + np.minimum.accumulate((h + g * s)[::-1])[::-1]
    return np.minimum(fwd, bwd)


def _place(graph, dense, edge_size, sheets, distance, shrink, floor) -> _State:
    """The first placement: spacing from the limits, grown at most GROWTH per
    unit arc, centres at that spacing, radii 0.9 times it."""
    curves, corners, ends = graph.curves, graph.corners, graph.ends
    n_c = len(corners)
    # Every dense point, with its curve and arc, for the distance limits.
    all_x = np.concatenate([d.x for d in dense] + [np.zeros((0, 3))])
    all_c = np.concatenate(
        [np.full(len(d.s), i) for i, d in enumerate(dense)] + [np.zeros(0, np.int64)]
    ).astype(np.int64)
    all_s = np.concatenate([d.s for d in dense] + [np.zeros(0)])
    tree = cKDTree(all_x) if len(all_x) else None
    # Corner radii.
    r_corner = np.zeros(n_c)
    if n_c:
        r_corner = np.asarray(edge_size(corners), float) * CORNER_FACTOR
        if n_c > 1:
            dc, _ = cKDTree(corners).query(corners, k=2)
            r_corner = np.minimum(r_corner, CORNER_GAP * dc[:, 1])
        r_corner = np.minimum(r_corner, _corner_curve_gap(corners, ends, tree, all_x, all_c))
        r_corner = np.maximum(r_corner, 0.0)
        if sheets is not None:
            r_corner = np.minimum(r_corner, _sheet_gap(corners, sheets, r_corner))
        for pts, reach in shrink:
            r_corner[_within(corners, pts, reach)] *= SHRINK
    # The curves' own limits (size, curvature, sheets away from corners).
    near_corner = np.zeros(len(all_x), bool)
    if n_c and len(all_x):
        dcy, jc = cKDTree(corners).query(all_x)
        # Sheets through a corner that a curve does not bound look like other
        # sheets from the curve near the corner: the corner's limit holds there.
        near_corner = dcy < 2.0 * r_corner[jc] / RADIUS_FACTOR
    offsets = np.r_[0, np.cumsum([len(d.s) for d in dense])]
    own = []
    for i, d in enumerate(dense):
        h = np.asarray(edge_size(d.x), float)
        h = np.minimum(h, CURVATURE / np.maximum(d.kappa, 1e-300))
        if distance is not None:
            h = np.minimum(h, np.sqrt(8.0 * distance / np.maximum(d.kappa, 1e-300)))
            # A chord across a polyline vertex that turns by t strays about
            # h t / 4 from it, more than the smooth estimate where h is short.
            h = np.minimum(h, 4.0 * distance / np.maximum(d.turn, 1e-300))
        if sheets is not None:
            far = ~near_corner[offsets[i] : offsets[i + 1]]
            h[far] = np.minimum(h[far], _sheet_gap(d.x[far], sheets, h[far]))
        for pts, reach in shrink:
            h[_within(d.x, pts, reach)] *= SHRINK
        own.append(h)
    # A corner's ball fits the spacing its curves allow next to it.
    for i, c in enumerate(curves):
        if not c.closed:
            a, b = ends[i]
            r_corner[a] = min(r_corner[a], CORNER_FACTOR * own[i][0])
            r_corner[b] = min(r_corner[b], CORNER_FACTOR * own[i][-1])
    # Dense points well inside a corner ball need no ball of their own, and
    # the distance between curves meeting at the corner goes to 0 there
    # (the first ball's centre is at least about half the radius out).
    in_corner = np.zeros(len(all_x), bool)
    if n_c and len(all_x):
        in_corner = dcy < CORNER_CORE * r_corner[jc]
    st = _State([], [], [], r_corner)
    for i, (c, d) in enumerate(zip(curves, dense, strict=True)):
        mine = slice(offsets[i], offsets[i + 1])
        gap = _curve_gap(d, i, c.closed, c.length, tree, all_c, all_s, in_corner, mine)
        h = np.minimum(own[i], gap)
        if h.min() < floor:
            k = int(np.argmin(h))
            raise FeatureError(
                f"cannot protect {c.label or 'a feature curve'} near "
                f"{np.round(d.x[k], 9).tolist()}: the balls there would be smaller than "
                f"{floor:.3g} (another curve, a corner or another sheet of the surface is "
                f"{h[k] / CURVE_GAP:.3g} away)",
                where=d.x[k],
            )
        if not c.closed:
            # Graded from the end corners' balls, as Mesh_3 interpolates sizes
            # between a curve's end balls: a large ball beside a small corner
            # ball nearly meets the first ball of the corner's other curve, and
            # refinement squeezes points, and triangles of 1 degree, into the gap.
            a, b = ends[i]
            h[0] = min(h[0], r_corner[a] / CORNER_FACTOR)
            h[-1] = min(h[-1], r_corner[b] / CORNER_FACTOR)
        h = _lipschitz(h, d.s, c.closed, c.length)
        if c.closed:
            s_k = _positions(d.s, h, True, c.length)
        else:
            a, b = ends[i]
            s_k = _open_positions(d, h, corners[a], r_corner[a], corners[b], r_corner[b])
        x = c.on_curve(s_k)
        ring = np.r_[x, x[:1]] if c.closed else np.r_[corners[[a]], x, corners[[b]]]
        gaps = row_norms(np.diff(ring, axis=0))
        near = np.minimum(gaps, np.roll(gaps, 1)) if c.closed else np.minimum(gaps[:-1], gaps[1:])
        # Also below the local limit at the ball itself (other curves, sheets).
        st.s.append(s_k)
        st.x.append(x)
        st.r.append(RADIUS_FACTOR * np.minimum(near, _at(s_k, d.s, h, c.closed, c.length)))
    return st


def _at(s_k: np.ndarray, s: np.ndarray, h: np.ndarray, closed: bool, length: float) -> np.ndarray:
    """``h`` (given at arc positions ``s``) at arc positions ``s_k``."""
    if closed:
        return np.interp(s_k, np.r_[s, length], np.r_[h, h[:1]])
    return np.interp(s_k, s, h)


def _positions(s: np.ndarray, h: np.ndarray, closed: bool, length: float) -> np.ndarray:
    """Arc positions of the centres of a closed curve (the first at arc 0),
    spaced about ``h``."""
    s_ = np.r_[s, length]
    h_ = np.r_[h, h[:1]]
    inv = 1.0 / h_
    steps = np.r_[0.0, np.cumsum(0.5 * (inv[1:] + inv[:-1]) * np.diff(s_))]
    total = steps[-1]
    n = max(3, int(np.ceil(total)))
    return np.interp(np.arange(n) * total / n, steps, s_)


def _open_positions(d: _Dense, h: np.ndarray, ca, ra: float, cb, rb: float) -> np.ndarray:
    """Arc positions of the centres of an open curve between corners ``ca``
    and ``cb`` (radii ``ra``, ``rb``): from where the curve leaves the first
    corner's ball to where it enters the last one's, the first and last a
    quarter spacing beyond those points (so they overlap the corner balls),
    spaced about ``h`` in between."""
    dist_a, dist_b = row_norms(d.x - ca), row_norms(d.x - cb)
    out_a = np.flatnonzero(dist_a >= ra)
    out_b = np.flatnonzero(dist_b >= rb)
    if not len(out_a) or not len(out_b):
        return np.zeros(0)
    i0, i1 = out_a[0], out_b[-1]
    if i0 >= i1:
        return np.zeros(0)  # the corner balls cover the curve: they must overlap
    # Where the curve leaves the balls, between dense points: the dense step
    # can exceed the spacing next to a corner (curves at a small angle).
    s0 = _crossing(d.s, dist_a, ra, i0, -1)
    s1 = _crossing(d.s, dist_b, rb, i1, 1)
    first = s0 + 0.25 * np.interp(s0, d.s, h)
    last = s1 - 0.25 * np.interp(s1, d.s, h)
    if last <= first:
        return np.array([0.5 * (s0 + s1)])
    keep = (d.s > first) & (d.s < last)
    s_ = np.r_[first, d.s[keep], last]
    h_ = np.r_[np.interp(first, d.s, h), h[keep], np.interp(last, d.s, h)]
    inv = 1.0 / h_
    steps = np.r_[0.0, np.cumsum(0.5 * (inv[1:] + inv[:-1]) * np.diff(s_))]
    n = max(1, int(np.ceil(steps[-1])))
    return np.interp(np.arange(n + 1) * steps[-1] / n, steps, s_)


def _crossing(s: np.ndarray, dist: np.ndarray, r: float, i: int, side: int) -> float:
    """The arc where ``dist`` (at arcs ``s``) crosses ``r`` between dense
    point ``i`` (outside) and its neighbour ``i + side`` (inside)."""
    j = i + side
    if j < 0 or j >= len(s) or dist[j] >= r:
        return float(s[i])
    t = (r - dist[j]) / max(dist[i] - dist[j], 1e-300)
    return float(s[j] + np.clip(t, 0.0, 1.0) * (s[i] - s[j]))


def _corner_curve_gap(corners, ends, tree, all_x, all_c) -> np.ndarray:
    """Per corner: CURVE_GAP times the distance to the nearest curve not ending at it."""
    out = np.full(len(corners), np.inf)
    if tree is None:
        return out
    k = min(64, len(all_x))
    d, j = tree.query(corners, k=k)
    d, j = d.reshape(len(corners), -1), j.reshape(len(corners), -1)
    own = np.zeros((len(corners), k), bool)
    for side in (0, 1):
        # A curve ending at the corner is incident to it.
        e = ends[:, side]
        own |= e[all_c[j]] == np.arange(len(corners))[:, None]
    d = np.where(own, np.inf, d)
    return CURVE_GAP * d.min(axis=1)


def _curve_gap(d, i, closed, length, tree, all_c, all_s, in_corner, mine) -> np.ndarray:
    """Per dense point of curve i: CURVE_GAP times the distance to other
    curves and far parts of curve i, ignoring points inside corner balls
    (``in_corner`` over every dense point; ``mine`` the slice of curve i's)."""
    k = min(48, len(all_c))
    dist, j = tree.query(d.x, k=k)
    dist, j = dist.reshape(len(d.s), -1), j.reshape(len(d.s), -1)
    same = all_c[j] == i
    gap = np.abs(all_s[j] - d.s[:, None])
    if closed:
        gap = np.minimum(gap, length - gap)
    local = same & (gap <= 2.0 * dist + 1e-12 * max(length, 1e-300))
    dist = np.where(local | in_corner[j], np.inf, dist)
    return np.where(in_corner[mine], np.inf, CURVE_GAP * dist.min(axis=1))


def _sheet_gap(x: np.ndarray, sheets, h: np.ndarray) -> np.ndarray:
    """SHEET_GAP times the distance from each point to surface samples whose
    tangent plane passes far from it (another sheet), among the nearest ones.
    ``sheets``: (points, unit normals), and optionally the points' KD-tree."""
    pts, nrm = sheets[:2]
    if len(pts) == 0 or len(x) == 0:
        return np.full(len(x), np.inf)
    k = min(24, len(pts))
    reach = float(np.max(h)) * 4.0 if np.all(np.isfinite(h)) else np.inf
    tree = sheets[2] if len(sheets) > 2 else cKDTree(pts)
    dist, j = tree.query(x, k=k, distance_upper_bound=reach)
    dist, j = dist.reshape(len(x), -1), j.reshape(len(x), -1)
    ok = j < len(pts)
    jj = np.minimum(j, len(pts) - 1)
    off = np.abs(np.einsum("ijk,ijk->ij", nrm[jj], pts[jj] - x[:, None, :]))
    # A sample on the point itself (a grid line through a volume's kink
    # curve) has no direction to judge: it is the curve's own.
    own = dist <= SAME_POINT * np.where(np.isfinite(h), h, 0.0)[:, None]
    other = ok & (off > 0.5 * dist) & ~own
    d = np.where(other, dist, np.inf)
    return SHEET_GAP * d.min(axis=1)


def _meeting(balls: Balls) -> np.ndarray:
    """Pairs of balls ``(k, 2)`` that meet (closed balls) but are not
    consecutive on a curve."""
    c, r = balls.centres, balls.radii
    if len(c) < 2:
        return np.zeros((0, 2), np.int64)
    pairs = cKDTree(c).query_pairs(2.0 * float(r.max()), output_type="ndarray")
    pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))].astype(np.int64).reshape(-1, 2)
    if len(pairs) == 0:
        return pairs
    i, j = pairs[:, 0], pairs[:, 1]
    d = row_norms(c[i] - c[j])
    meet = d <= (r[i] + r[j]) * (1.0 + 1e-9)
    n = len(c)
    key = np.minimum(i, j) * n + np.maximum(i, j)
    p = balls.pairs
    cons = np.minimum(p[:, 0], p[:, 1]) * n + np.maximum(p[:, 0], p[:, 1])
    meet &= ~np.isin(key, cons)
    return pairs[meet]
