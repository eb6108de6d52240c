"""Dual segments whose crossings a slope bound rules out (issue 30).

``f`` is first known at the ends of each dual segment (its Voronoi
vertices). A segment whose ends have one sign is left unsampled when
``|f(a)| + |f(b)| > L |b - a|``: a crossing on it would need ``f`` to fall
from ``|f(a)|`` to 0 and rise again to ``|f(b)|`` over ``|b - a|``, a slope
above ``L``. Every other segment is sampled as before, all its samples, so
its crossings are those of the full sampling.

With ``L`` proven (the surface's ``lipschitz``: a signed distance's 1) no
crossing is lost this way. Otherwise ``L`` is an estimate, ``SAFETY`` times
the steepest slope seen: between neighbouring nodes of the seeding grid, over
the ball for long segments and within ``FIELD_CELLS`` spacings for short ones
(:class:`SlopeField`), raised where the segments' ends show a steeper one.
The result then rests on that estimate: a steeper place than the grid and the
segments saw can hide a pair of crossings, as one between samples can.
Halving the other segments by the same rule found no further samples to skip
on the public surfaces (torus 41.1 against 41.3 samples per vertex), so they
are not halved.

Most dual segments lie far from the surface. The core clears those before
handing them out (:func:`clear_in_core`): a segment within distance ``D`` of a
grid node where ``|f| > L D`` has no zero, so its facet is not restricted, and
neither its ends nor its samples are evaluated. Where the grid clears too little
(about a thin part's core) :mod:`rdmesh.sampling.fine_clearing` adds a finer level."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from .. import core
from ..surfaces.oracle import ImplicitSurface

#: An estimated bound is this many times the steepest slope seen.
SAFETY = 2.0
#: Segments shorter than this, times R, give no slope (their difference is rounding).
MIN_STEP = 1e-7
#: Segments up to this many grid spacings long take the local bound of the
#: grid nodes about their middle; the field covers this many spacings about
#: each node (REACH / 2 + sqrt(3) / 2 < FIELD_CELLS).
REACH, FIELD_CELLS = 2.0, 2


class SlopeField:
    """Local slopes of ``f`` from the seeding grid: at each node, the largest
    ``|grad f|`` estimate (:func:`node_slopes`) of the nodes within
    ``FIELD_CELLS`` spacings (kept in a :class:`rdmesh.core.GridField`).

    Parameters
    ----------
    values : (n, n, n) ``f`` at the grid's nodes.
    h : the grid spacing.
    centre, rotation, offset : node ``(i, j, k)`` lies at
        ``centre + (h * (i, j, k) - offset) @ rotation.T``.
    within : (n, n, n) bool, the nodes in the bounding ball.

    Attributes
    ----------
    in_ball : the largest estimate at the nodes in the ball.
    """

    def __init__(self, values: np.ndarray, h: float, centre, rotation, offset, within) -> None:
        node = node_slopes(values, h)
        #: Each node's own estimate, flat in C order (the fine clearing's floor).
        self.node_slopes = node.ravel()
        inside = node[within]
        self.in_ball = float(inside.max()) if inside.size else 0.0
        near = ndimage.maximum_filter(node, size=2 * FIELD_CELLS + 1, mode="nearest")
        self.h = float(h)
        self.grid = core.GridField(near, centre, rotation, offset, h)
        #: f itself at the nodes: the core clears the segments near a node
        #: whose |f| the bound cannot bring to 0 (``set_clearing``).
        self.values = core.GridField(values, centre, rotation, offset, h)

    @classmethod
    def proven(cls, lower: np.ndarray, h: float, centre, rotation, offset, lip: float):
        """For a ``lip``-Lipschitz ``f``: the slope ``lip`` everywhere, and
        ``lower``, a value of ``f``'s sign whose size is at most ``|f|`` at
        each node (a grid that skips nodes knows only that much there)."""
        field = cls.__new__(cls)
        field.in_ball, field.h = float(lip), float(h)
        field.node_slopes = np.full(lower.size, float(lip))
        field.grid = core.GridField(np.full(lower.shape, float(lip)), centre, rotation, offset, h)
        field.values = core.GridField(lower, centre, rotation, offset, h)
        return field

    def at(self, points: np.ndarray) -> np.ndarray:
        """The local slope at each point; inf off the grid."""
        return self.grid.at(points)


@dataclass
class SlopeBound:
    """A bound on ``|grad f|`` inside the bounding ball.

    Attributes
    ----------
    value : float
        The bound for the whole ball.
    proven : bool
        ``value`` is the surface's own Lipschitz constant; otherwise an
        estimate that :meth:`observe` raises when it sees a steeper slope.
    field : SlopeField or None
        Local estimates, for short segments (``SAFETY`` times the field).
    """

    value: float
    proven: bool
    field: SlopeField | None = None

    def for_segments(self, seg: np.ndarray) -> np.ndarray:
        """The bound that holds along each segment (k, 2, 3)."""
        if self.field is None or not len(seg):
            return np.full(len(seg), self.value)
        reach = REACH * self.field.h
        return self.field.grid.segment_bounds(seg, reach, SAFETY, self.value)

    def observe(self, seg: np.ndarray, steep: np.ndarray, used: np.ndarray) -> None:
        """Raise an estimate where ``steep`` (the slopes seen along each
        segment) exceeds what the bound ``used`` there expected."""
        if self.proven or not len(seg):
            return
        self.value = max(self.value, SAFETY * float(steep.max()))
        over = np.flatnonzero(SAFETY * steep > used)
        if self.field is not None and len(over):
            mid = 0.5 * (seg[over, 0] + seg[over, 1])
            self.field.grid.raise_to(mid, steep[over], FIELD_CELLS)


def clear_in_core(rdt: core.RestrictedDelaunay, bound: SlopeBound | None) -> bool:
    """Let the core clear, without handing them out, the facets whose
    segment lies near a grid node with ``|f|`` above the bound times the
    node's distance to every point of it (with a proven bound, ``|f|`` at a
    node is a proven lower bound: :meth:`SlopeField.proven`); whether it can."""
    if bound is None or bound.field is None:
        return False
    field = bound.field
    rdt.set_clearing(field.values, field.grid, SAFETY, REACH * field.h, bound.value)
    return True


def slope_bound(surface: ImplicitSurface, field: SlopeField | None) -> SlopeBound | None:
    """The surface's proven bound, else estimates from the seeding grid
    (None when it measured nothing)."""
    lip = getattr(surface, "lipschitz", None)
    if lip is not None:
        # With the grid's proven field the core clears far facets too.
        return SlopeBound(float(lip), True, field)
    if field is None:
        return None
    # Over the ball, every segment's bound before the field's local ones.
    return SlopeBound(SAFETY * field.in_ball, False, field)


def node_slopes(values: np.ndarray, h: float) -> np.ndarray:
    """At each node of a grid of spacing ``h``, ``|grad f|`` estimated from
    its edges: along each axis the steeper of its two edges' ``|f(q) - f(p)|
    / h``, the three combined as a vector's length (so that a gradient along
    a diagonal counts whole); inf where ``f`` is not finite."""
    out = np.zeros(values.shape)
    for ax in range(values.ndim):
        d = np.abs(np.diff(values, axis=ax)) / h
        d = np.where(np.isfinite(d), d, np.inf)
        lo = [slice(None)] * values.ndim
        hi = [slice(None)] * values.ndim
        lo[ax], hi[ax] = slice(0, -1), slice(1, None)
        steep = np.zeros(values.shape)
        np.maximum(steep[tuple(lo)], d, out=steep[tuple(lo)])
        np.maximum(steep[tuple(hi)], d, out=steep[tuple(hi)])
        out = np.hypot(out, steep)  # squares overflow for f scaled by 1e200
    return out


def ruled_out(ends: np.ndarray, length: np.ndarray, bound: np.ndarray | float) -> np.ndarray:
    """Which segments the bound clears of crossings (module docstring):
    ``ends`` (k, 2) ``f`` at their ends, ``length`` (k,) their lengths."""
    same = (ends[:, 0] < 0) == (ends[:, 1] < 0)
    return same & (np.abs(ends[:, 0]) + np.abs(ends[:, 1]) > bound * length)


def end_slopes(ends: np.ndarray, length: np.ndarray, radius: float) -> np.ndarray:
    """``|f(b) - f(a)| / |b - a|`` of each segment (0 below ``MIN_STEP`` R)."""
    out = np.zeros(len(length))
    return np.divide(
        np.abs(ends[:, 1] - ends[:, 0]), length, out=out, where=length > MIN_STEP * radius
    )
