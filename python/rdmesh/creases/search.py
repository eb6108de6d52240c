"""Creases and corners found in expressions and CSG trees (../shared/design/creases.md 3.1-3.2).

A surface whose function is an expression (:meth:`rdmesh.ImplicitSurface.from_expression`)
or a tree made by :mod:`rdmesh.csg` is smooth except where a ``min``, ``max``
or ``abs`` node that reaches ``f`` switches branch
(:class:`~rdmesh.surfaces.pieces.PieceModel`). Holding every node on the
branch it takes gives a smooth *piece* ``F`` with an exact gradient. A
**crease** is where two pieces meet at an angle: the curve ``{F = 0, s = 0}``
for the switch ``s`` of one node (``a - b`` for ``min(a, b)``, ``u`` for
``abs(u)``), where the gradients of the two pieces are not parallel. A
**corner** is where a third piece joins: another node switches on the curve.

How they are found:

1. **Seeds.** Every crossing of the seeding grid (:func:`~rdmesh.sampling.grid.grid_scan`,
   the same grid the mesher seeds with) is labelled by its pieces; each pair of
   crossings closer than two grid cells with different labels brackets a crease
   of the highest node where they differ. Its midpoint is projected onto that
   crease by minimum-norm Gauss-Newton (:func:`~rdmesh.creases.tracing.newton_project`).
2. **Tracing** (:func:`~rdmesh.creases.tracing.trace`), from one seed of each
   crease at a time, both ways, until the curve closes or a third piece joins.
3. **Corners**: Newton on the three equations (piece, both switches), bracketed
   by the last two points of the trace (bisection along the curve where
   Newton fails).
4. **Completeness** (expressions): an octree of boxes over the bounding ball
   is subdivided where interval arithmetic (``rdmesh.core.evaluate_intervals``)
   cannot exclude a crease: a box holds none when ``0`` is not in ``f(box)``,
   or when every node's switch excludes ``0`` or the node cannot reach ``f``
   there (a ``min``/``max`` above it provably takes the other branch).
   Boxes at the search's size that still may hold one are *explained* when a
   traced crease passes through them; otherwise Gauss-Newton from the box
   centre looks for a crease there (a new one is traced), a tie with parallel
   gradients (a smooth join: settled, sampled), or nothing, and the box is
   split further. Boxes still unsettled at :data:`FLOOR` ``x R`` are
   reported as *unresolved*: a crease the seeds missed (a small loop) is
   never dropped silently.

Not creases: ties where the pieces' gradients are parallel (smooth joins,
:data:`MIN_ANGLE`), and points where the piece and the switch surface touch
(their gradients parallel: the trace is lost there and the place reported).
``sign``, ``floor`` and ``ceil`` (jumps) are refused.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from .._errors import BoundingSphereError, EmptySurfaceError
from .._vectors import row_norms
from ..features.graph import FeatureCurve, FeatureError
from ..sampling.grid import grid_scan
from ..surfaces.expressions import Expression
from ..surfaces.pieces import PieceModel, PiecewiseFunction
from .boxes import CREASE, NOTHING, SMOOTH, settle
from .system import CreaseSystem, Projection, solve_corner
from .tracing import newton_project, trace

log = logging.getLogger("rdmesh")

#: Pieces whose gradients make a smaller angle (degrees) meet smoothly: no crease.
MIN_ANGLE = 1.0
#: A piece and a switch with gradients closer to parallel (sine) touch: not traced.
TOUCH = 1e-6
#: Pieces whose gradients are opposite to within this many degrees are two
#: sheets that touch (a pinch), not a crease nor a smooth join.
TOUCH_ANGLE = 0.1
#: Residual tolerance of the corrector while tracing, times R.
TRACE_TOL = 1e-10
#: Residual tolerance of the exact projection onto a crease, times R.
PROJECT_TOL = 1e-14
#: Smallest tracing step, times R: below it a trace is lost.
MIN_STEP = 1e-7
#: Largest tracing step, times the seeding grid's spacing.
STEP = 0.5
#: Labels of a crease's two sides are taken this far off it, times R.
SIDE = 1e-7
#: Tracing rounds at most (each traces one seed of every crease not yet found).
MAX_ROUNDS = 64


def piece_model(surface: Any) -> PieceModel | None:
    """The piece structure of a surface's function: an expression's or a CSG
    tree's (None for any other function, or one without ``min``, ``max`` or
    ``abs``)."""
    f = getattr(surface, "f", None)
    if isinstance(f, Expression):
        model = f.pieces
    elif isinstance(f, PiecewiseFunction):
        model = f.model
    else:
        return None
    return model if model.size else None


@dataclass
class CreaseSearch:
    """The creases and corners found on a surface, and what the search settled.

    Attributes
    ----------
    curves : list of FeatureCurve
        Each crease from corner to corner (or closed), with an exact
        projection onto ``{F = 0, s = 0}``.
    unresolved : (k, 3) float64
        Places where a crease could be neither excluded nor found (boxes at
        the floor size, e.g. where two sheets touch, or a trace that was
        lost): one point per region (the mean of the places within a grid
        cell of each other).
    boxes : dict
        Boxes of the interval search by outcome: "excluded" (proven to hold
        no crease), "traced" (a traced crease passes through), "smooth"
        (a tie with parallel gradients: a smooth join, sampled),
        "unresolved"; empty without intervals (CSG trees of plain functions).
    seeds : int
        Seeds projected onto creases.
    level : str
        "intervals" (every box settled or reported) or "sampled" (seeds from
        the grid only).
    seconds : float
    """

    curves: list[FeatureCurve] = field(default_factory=list)
    unresolved: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    boxes: dict = field(default_factory=dict)
    seeds: int = 0
    level: str = "sampled"
    seconds: float = 0.0
    note: str = ""

    @property
    def corners(self) -> np.ndarray:
        """The end points of the open curves, ``(c, 3)`` (shared ones repeated)."""
        ends = [c.points[[0, -1]] for c in self.curves if not c.closed]
        return np.concatenate(ends) if ends else np.zeros((0, 3))

    def as_report(self) -> dict[str, Any]:
        """The report's ``creases`` entry (plain types)."""
        return {
            "curves": len(self.curves),
            "closed": sum(c.closed for c in self.curves),
            "corners": len(np.unique(np.round(self.corners, 9), axis=0)),
            "seeds": self.seeds,
            "level": self.level,
            "boxes": dict(self.boxes),
            "unresolved": np.round(self.unresolved, 12).tolist(),
            "seconds": round(self.seconds, 4),
            "note": self.note,
        }


def creases_from_crossings(
    surface: Any,
    crossings: np.ndarray,
    spacing: float,
    *,
    intervals: bool = True,
    t0: float | None = None,
) -> CreaseSearch | None:
    """The creases and corners of a surface built from ``min``, ``max`` and
    ``abs`` (an expression, or a tree made by :mod:`rdmesh.csg`), seeded
    from the crossings of a grid
    (:func:`find_creases` scans the mesher's).

    Parameters
    ----------
    surface : ImplicitSurface
    crossings : (n, 3) float64
        Points on the surface where the grid's edges cross it.
    spacing : float
        The grid's cell size.
    intervals : bool
        Settle the rest by interval arithmetic (expressions only).
    t0 : float, optional
        ``time.perf_counter()`` when the search began (the scan included).

    Returns
    -------
    CreaseSearch or None
        None when the function has no such structure (nothing to search).

    Raises
    ------
    FeatureError
        The expression uses ``sign``, ``floor`` or ``ceil`` (not piecewise
        smooth).
    """
    t0 = time.perf_counter() if t0 is None else t0
    model = piece_model(surface)
    if model is None:
        return None
    refuse_steps(model, getattr(surface, "name", "the surface"))
    R = surface.radius
    search = _Search(model, surface.centre, R, spacing)
    search.add_seeds(*crossing_seeds(model, crossings, spacing))
    search.run()
    boxes: dict = {}
    level = "sampled"
    if intervals and isinstance(surface.f, Expression):
        boxes = settle(surface.f, search)
        level = "intervals"
    out = CreaseSearch(
        curves=feature_curves(search),
        unresolved=_regions(search.unresolved_points(), spacing),
        boxes=boxes,
        seeds=search.n_seeds,
        level=level,
        seconds=time.perf_counter() - t0,
    )
    log.info(
        "creases: %d curves (%d closed), %d unresolved places, %.3g s",
        len(out.curves), sum(c.closed for c in out.curves), len(out.unresolved), out.seconds,
    )  # fmt: skip
    if len(out.unresolved):
        log.warning(
            "creases: %d places where a crease could be neither excluded nor traced "
            "(e.g. %s); see report['creases']['unresolved']",
            len(out.unresolved), np.round(out.unresolved[0], 6).tolist(),
        )  # fmt: skip
    return out


def find_creases(
    surface: Any, *, seed: int = 0, resolution: int = 64, intervals: bool = True
) -> CreaseSearch | None:
    """The creases and corners of a surface built from ``min``, ``max`` and
    ``abs`` (an expression, or a tree made by :mod:`rdmesh.csg`), seeded from
    the crossings of the mesher's seeding grid
    (:func:`~rdmesh.creases.search.creases_from_crossings`).

    Parameters
    ----------
    surface : ImplicitSurface
    seed : int
        Seed of the grid's rotation (the mesher's own, so that the crossings
        are the same).
    resolution : int
        Cells of the seeding grid across the bounding ball.
    intervals : bool
        Settle the rest by interval arithmetic (expressions only).

    Returns
    -------
    CreaseSearch or None
        None when the function has no such structure (nothing to search).

    Raises
    ------
    FeatureError
        The expression uses ``sign``, ``floor`` or ``ceil`` (not piecewise
        smooth).
    """
    t0 = time.perf_counter()
    model = piece_model(surface)
    if model is None:
        return None
    refuse_steps(model, getattr(surface, "name", "the surface"))
    try:
        scan = grid_scan(surface, np.random.default_rng(seed), resolution)
    except (BoundingSphereError, EmptySurfaceError):
        # The mesher's own scan raises the same error.
        return CreaseSearch(seconds=time.perf_counter() - t0)
    return creases_from_crossings(
        surface, scan.crossings, scan.spacing, intervals=intervals, t0=t0
    )


def crossing_seeds(
    model: PieceModel, crossings: np.ndarray, spacing: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Midpoints of crossings closer than two grid cells with different
    labels, the highest node where their labels differ, and the branches of
    both merged (that node on its first branch): ``(points, key, node)``."""
    empty = np.zeros((0, 3)), np.zeros((0, model.size), np.int8), np.zeros(0, np.int64)
    if len(crossings) < 2:
        return empty
    label = model.evaluate(crossings).label
    pairs = cKDTree(crossings).query_pairs(2.0 * spacing, output_type="ndarray")
    if not len(pairs):
        return empty
    p, q = pairs[:, 0], pairs[:, 1]
    differ = label[p] != label[q]
    use = differ.any(axis=1)
    p, q, differ = p[use], q[use], differ[use]
    k = np.argmax(differ, axis=1)
    key = np.where(label[p] >= 0, label[p], label[q]).astype(np.int8)
    key[np.arange(len(k)), k] = 0
    return 0.5 * (crossings[p] + crossings[q]), key, k


def refuse_steps(model: PieceModel, name: str) -> None:
    """FeatureError when the tree uses a step function on a variable."""
    steps = model.steps()
    if steps:
        raise FeatureError(
            f"{name!r} uses {', '.join(steps)}: its surface jumps, and creases are found only "
            "where min, max and abs switch; pass features='none' to mesh it without creases"
        )


class CreaseTable:
    """The creases met so far, each by the branches on its side A
    (``forced``), its switching node (``node``) and the nodes that switch
    together across it (``delta``)."""

    def __init__(self, model: PieceModel) -> None:
        self.model = model
        self.keys: dict[bytes, int] = {}
        self.forced = np.zeros((0, model.size), np.int8)
        self.delta = np.zeros((0, model.size), bool)
        self.node = np.zeros(0, np.int64)

    @property
    def system(self) -> CreaseSystem:
        return CreaseSystem(self.model, self.forced, self.node, self.delta)

    def crease_of(self, key: np.ndarray, node: np.ndarray, delta: np.ndarray) -> np.ndarray:
        """The crease index of each (side-A branches, node, switching nodes),
        new ones added."""
        if not len(node):
            return np.zeros(0, np.int64)
        rows = np.column_stack([key.astype(np.int64), delta.astype(np.int64), node])
        uniq, inverse = np.unique(rows, axis=0, return_inverse=True)
        index = np.empty(len(uniq), np.int64)
        d = self.model.size
        for u, row in enumerate(uniq):  # one per crease, not per seed
            b = row.tobytes()
            if b not in self.keys:
                self.keys[b] = len(self.node)
                self.forced = np.r_[self.forced, row[None, :d].astype(np.int8)]
                self.delta = np.r_[self.delta, row[None, d : 2 * d].astype(bool)]
                self.node = np.r_[self.node, row[-1]]
            index[u] = self.keys[b]
        return index[inverse.reshape(-1)]


class _Search:
    """The state of one search: seeds grouped by crease, the curves traced."""

    def __init__(self, model: PieceModel, centre: np.ndarray, R: float, spacing: float) -> None:
        self.model, self.centre, self.R = model, np.asarray(centre, float), R
        self.spacing = spacing
        self.h_max = STEP * spacing
        self.table = CreaseTable(model)
        # Seeds: point and crease (index into forced / node).
        self.seed_x = np.zeros((0, 3))
        self.seed_c = np.zeros(0, np.int64)
        self.n_seeds = 0
        # Traced curves: points, closed, crease, how each end ended.
        self.traced: list[tuple[np.ndarray, bool, int]] = []
        self.lost: list[np.ndarray] = []

    @property
    def system(self) -> CreaseSystem:
        return self.table.system

    @property
    def node(self) -> np.ndarray:
        """The switching node of each crease."""
        return self.table.node

    def add_seeds(self, x: np.ndarray, key: np.ndarray, node: np.ndarray) -> None:
        """Project candidate seeds onto their creases and keep the valid ones."""
        if not len(x):
            return
        # One candidate per (crease, place): duplicates only cost Newton steps.
        cell = np.floor((x - self.centre) / (0.25 * self.spacing)).astype(np.int64)
        _, first = np.unique(
            np.column_stack([cell, node, key.astype(np.int64)]), axis=0, return_index=True
        )
        first = np.sort(first)
        self.classify(x[first], key[first], node[first])

    def classify(
        self, x: np.ndarray, key: np.ndarray, node: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Project points onto the creases of nodes ``node`` near them (side A
        branches ``key``) and keep the crease points as seeds.

        Returns the projected points and an outcome per point: :data:`CREASE`
        (a crease point, kept as a seed), :data:`SMOOTH` (a tie where the
        pieces' gradients are parallel) or :data:`NOTHING` (Newton failed, or
        went more than two grid cells, or two sheets touch there)."""
        rows = np.arange(len(x))
        delta = np.zeros(key.shape, bool)
        delta[rows, node] = True
        c = self.table.crease_of(key, node, delta)
        y, ok, _ = newton_project(self.system, x, c, TRACE_TOL * self.R)
        ok &= row_norms(y - x) <= 2.0 * self.spacing
        # The branches on both sides of the switch surface at the point: the
        # nodes that switch together there, and the crease they make.
        c, ok = self._canonical(y, c, ok)
        system = self.system
        y, done, sine = newton_project(system, y, c, TRACE_TOL * self.R)
        r = self.model.evaluate(y, system.forced[c])
        ok &= done & (sine >= TOUCH) & r.reachable[rows, system.node[c]]
        ok &= system.event(r, c) < 0
        angle = np.zeros(len(y))
        if ok.any():
            angle[ok] = system.pieces_angle(y[ok], c[ok])
        ok &= angle <= 180.0 - TOUCH_ANGLE
        out = np.where(ok, np.where(angle >= MIN_ANGLE, CREASE, SMOOTH), NOTHING)
        keep = out == CREASE
        self.seed_x = np.r_[self.seed_x, y[keep]]
        self.seed_c = np.r_[self.seed_c, c[keep]]
        self.n_seeds += int(keep.sum())
        return y, out

    def _canonical(self, y: np.ndarray, c: np.ndarray, ok: np.ndarray):
        """The crease through points ``y`` found on the switch of ``node[c]``:
        the labels just off the switch surface on each side, the nodes
        reachable on both sides whose branches differ (they switch together),
        side A the one where the first of them takes its first branch."""
        node = self.node[c]
        r = self.model.evaluate(y)
        rows = np.arange(len(y))
        n = r.switch_grad[rows, node]
        n /= np.maximum(row_norms(n), 1e-300)[:, None]
        step = SIDE * self.R * n
        la, lb = self.model.evaluate(y - step).label, self.model.evaluate(y + step).label
        delta = (la >= 0) & (lb >= 0) & (la != lb)
        ok = ok & delta[rows, node]
        k = np.argmax(delta, axis=1)
        swap = la[rows, k] == 1
        la, lb = np.where(swap[:, None], lb, la), np.where(swap[:, None], la, lb)
        key = np.where(la >= 0, la, lb).astype(np.int8)
        return self.table.crease_of(key, k, delta), ok

    def run(self) -> None:
        """Trace one seed of every crease with seeds left, until none is left."""
        for _ in range(MAX_ROUNDS):
            keep = _untraced(self.seed_x, self.seed_c, self.traced, 0.05 * self.h_max)
            self.seed_x, self.seed_c = self.seed_x[keep], self.seed_c[keep]
            if not len(self.seed_c):
                return
            _, first = np.unique(self.seed_c, return_index=True)
            starts, crease = self.seed_x[first], self.seed_c[first]
            self.seed_x = np.delete(self.seed_x, first, axis=0)
            self.seed_c = np.delete(self.seed_c, first)
            self._trace(starts, crease)
        log.warning("creases: tracing stopped after %d rounds", MAX_ROUNDS)
        self.lost.append(self.seed_x)
        self.seed_x, self.seed_c = np.zeros((0, 3)), np.zeros(0, np.int64)

    def _trace(self, starts: np.ndarray, crease: np.ndarray) -> None:
        system, R = self.system, self.R
        kw = dict(
            h_max=self.h_max, h_min=MIN_STEP * R, tol=TRACE_TOL * R,
            ball=(self.centre, R * (1 + 1e-9)), max_steps=int(400 * R / self.h_max) + 100,
        )  # fmt: skip
        m = len(starts)
        fwd = trace(system, starts, crease, np.ones(m), **kw)
        again = np.flatnonzero(fwd.end != "closed")
        bwd = trace(system, starts[again], crease[again], -np.ones(len(again)), **kw)
        back = {int(i): j for j, i in enumerate(again)}
        for i in range(m):
            if fwd.end[i] == "closed":
                self._accept(fwd.points[i], True, int(crease[i]))
                continue
            head = _finish(self, bwd, back[i], int(crease[i]))
            tail = _finish(self, fwd, i, int(crease[i]))
            self._accept(np.concatenate([head[::-1], tail[1:]]), False, int(crease[i]))

    def _accept(self, pts: np.ndarray, closed: bool, crease: int) -> None:
        """Keep a traced curve unless it repeats one already kept."""
        pts = _thin(pts, 1e-3 * self.h_max, closed)
        if len(pts) < (3 if closed else 2):
            return
        for other, _, c in self.traced:
            if c == crease and _near_polyline(pts, other, 0.05 * self.h_max).mean() > 0.5:
                return
        self.traced.append((pts, closed, crease))

    def unresolved_points(self) -> np.ndarray:
        return np.concatenate(self.lost) if self.lost else np.zeros((0, 3))


def _finish(search: _Search, tr, i: int, crease: int) -> np.ndarray:
    """The points of trace ``i``, its last one replaced by the corner when
    it ended past one (and the place noted when it was lost)."""
    pts = tr.points[i]
    if tr.end[i] in ("lost", "steps"):
        search.lost.append(pts[-1:])
    if tr.end[i] != "event":
        return pts
    before = pts[-2] if len(pts) > 1 else pts[-1]
    corner = solve_corner(
        search.system, before, pts[-1], crease, int(tr.event[i]), PROJECT_TOL * search.R
    )
    return np.r_[pts[:-1], corner[None]]


def feature_curves(search: _Search) -> list[FeatureCurve]:
    """The traced creases as feature curves with exact projections."""
    out = []
    for i, (pts, closed, c) in enumerate(search.traced):
        project = Projection(search.system, c, PROJECT_TOL * search.R)
        out.append(FeatureCurve(pts, closed, "crease", project, f"crease {i}"))
    return out


def _regions(points: np.ndarray, link: float) -> np.ndarray:
    """One point per cluster of ``points`` (chains of points closer than
    ``link`` to one of their 8 nearest), the mean of each, in order of first
    appearance; memory linear in the points."""
    n = len(points)
    if n < 2:
        return points
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    d, j = cKDTree(points).query(points, k=min(9, n), distance_upper_bound=link)
    i = np.repeat(np.arange(n), d.shape[1])
    near = np.isfinite(d.ravel())
    g = coo_matrix((np.ones(int(near.sum())), (i[near], j.ravel()[near])), shape=(n, n))
    _, label = connected_components(g, directed=False)
    _, first, label = np.unique(label, return_index=True, return_inverse=True)
    order = np.argsort(np.argsort(first))
    label = order[label.reshape(-1)]
    count = np.bincount(label)
    return np.stack([np.bincount(label, weights=points[:, a]) / count for a in range(3)], 1)


def _untraced(x: np.ndarray, crease: np.ndarray, traced: list, tol: float) -> np.ndarray:
    """Which seeds (points ``x`` of creases ``crease``) lie on no traced
    curve of their crease (within ``tol``)."""
    keep = np.ones(len(crease), bool)
    for pts, closed, c in traced:
        mine = np.flatnonzero(keep & (crease == c))
        if len(mine):
            line = np.r_[pts, pts[:1]] if closed else pts
            keep[mine[_near_polyline(x[mine], line, tol)]] = False
    return keep


def _thin(pts: np.ndarray, tol: float, closed: bool) -> np.ndarray:
    """Consecutive points closer than ``tol`` as one (the ends kept)."""
    if len(pts) < 2:
        return pts
    step = row_norms(np.diff(pts, axis=0))
    keep = np.r_[True, step > tol]
    if not closed:
        keep[-1] = True
        if step[-1] <= tol and len(pts) > 2:
            keep[-2] = False
    out = pts[keep]
    if closed and len(out) > 1 and row_norms(out[-1:] - out[:1])[0] <= tol:
        out = out[:-1]
    return out


def _near_polyline(points: np.ndarray, line: np.ndarray, tol: float) -> np.ndarray:
    """Which points lie within ``tol`` of the polyline ``line`` ``(k, 3)``."""
    if len(line) < 2 or not len(points):
        return np.zeros(len(points), bool)
    a, b = line[:-1], line[1:]
    mid, half = 0.5 * (a + b), 0.5 * row_norms(b - a)
    hits = cKDTree(mid).query_ball_point(points, float(half.max()) + tol)
    i = np.repeat(np.arange(len(points)), [len(h) for h in hits])
    s = np.concatenate([np.asarray(h, np.int64) for h in hits]) if len(i) else np.zeros(0, int)
    if not len(i):
        return np.zeros(len(points), bool)
    d = b[s] - a[s]
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    w = np.clip(np.einsum("ij,ij->i", points[i] - a[s], d) / dd, 0.0, 1.0)
    dist = row_norms(a[s] + w[:, None] * d - points[i])
    out = np.zeros(len(points), bool)
    out[i[dist <= tol]] = True
    return out


__all__ = [
    "CreaseSearch",
    "creases_from_crossings",
    "crossing_seeds",
    "find_creases",
    "piece_model",
    "refuse_steps",
]
