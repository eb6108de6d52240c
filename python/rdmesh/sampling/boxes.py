"""Interval subdivision of the bounding cube: where an expression surface may be.

For surfaces given as expressions, interval arithmetic
(:mod:`rdmesh.surfaces.intervals`) bounds ``f`` on whole boxes: a box where
``0`` is outside the bounds holds no point of the surface, a proof. The cube
around the bounding sphere is split into 8 again and again, keeping only boxes
that may hold the surface, down to boxes a fraction of the seeding grid's
cell. In each kept box a surface point is looked for: a sign change between
its corners and centre (then root finding on that segment), or else Newton's
method from its centre. Components smaller than the seeding grid, which the
grid misses, are found this way when a box that holds them yields a point;
that last step is a search, not a proof (see issue 13: Plantinga-Vegter).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .._newton import damped_step
from .._tol import ON_SURFACE, SHOT_ATOL, TINY
from .._vectors import row_norms
from ..surfaces.expressions import Expression
from ..surfaces.oracle import ImplicitSurface
from .roots import SegmentSamples, line_crossings

log = logging.getLogger("rdmesh")

#: Boxes kept at one level at most (memory: about 100 bytes a box).
MAX_BOXES = 1 << 20
#: Newton steps from a box centre without a sign change.
NEWTON_STEPS = 8

# The 8 corners of a unit box, then its centre.
_POINTS = np.array(
    [[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)] + [[0.5, 0.5, 0.5]], float
)


@dataclass
class BoxSearch:
    """Result of :func:`interval_boxes`.

    Attributes
    ----------
    points : (m, 3) surface points, at most one per kept box away from the
        known points.
    boxes : number of boxes that may hold the surface at the last level.
    side : side of those boxes.
    empty_proven : True when every box left out was proven free of the surface
        (no level was cut short by :data:`MAX_BOXES`).
    """

    points: np.ndarray
    boxes: int
    side: float
    empty_proven: bool


def interval_boxes(
    surface: ImplicitSurface,
    expr: Expression,
    side: float,
    rng: np.random.Generator,
    known: np.ndarray | None = None,
) -> BoxSearch:
    """Subdivide the cube around the bounding sphere down to boxes of about ``side``.

    Parameters
    ----------
    surface : ImplicitSurface whose ``f`` is ``expr``.
    expr : Expression
    side : target box side (the grid spacing over a few).
    rng : numpy Generator for a small random shift of the cube.
    known : (k, 3) surface points already known; boxes within ``side`` of one
        are not searched (they return no point).
    """
    c0, R = surface.centre, surface.radius
    half = R * (1.0 + 0.01 * rng.uniform())
    lo = (c0 - half + 0.001 * R * rng.uniform(-1, 1, 3))[None, :]
    size = 2.0 * half
    proven = True
    while True:
        flo, fhi, undefined = expr.interval(lo, lo + size)
        # The nearest point of each box to the centre: boxes outside the
        # sphere hold no part of the surface meshed.
        near = np.clip(c0, lo, lo + size)
        keep = ((flo <= 0) & (fhi >= 0) | undefined) & (row_norms(near - c0) < R)
        lo = lo[keep]
        if size <= side or len(lo) == 0:
            break
        if 8 * len(lo) > MAX_BOXES:
            proven = False
            break
        size *= 0.5
        lo = (lo[:, None, :] + size * _POINTS[None, :8]).reshape(-1, 3)
    n_boxes = len(lo)
    if known is not None and len(known) and len(lo):
        d, _ = cKDTree(known).query(lo + 0.5 * size)
        lo = lo[d > size]
    points = _point_in_each(surface, lo, size)
    log.info(
        "interval boxes: %d of side %.3g may hold the surface; %d points found",
        n_boxes, size, len(points),
    )  # fmt: skip
    return BoxSearch(points, n_boxes, size, proven)


def _point_in_each(surface: ImplicitSurface, lo: np.ndarray, size: float) -> np.ndarray:
    """A surface point for each box, where the search finds one."""
    if len(lo) == 0:
        return np.zeros((0, 3))
    R = surface.radius
    pts = lo[:, None, :] + size * _POINTS[None]  # (n, 9, 3)
    f = surface(pts.reshape(-1, 3)).reshape(len(lo), 9)
    inside = f < 0
    # A sign change between the centre and a corner: root finding on it.
    other = inside != inside[:, 8:9]
    has = other[:, :8].any(axis=1)
    corner = np.argmax(other[:, :8], axis=1)
    rows = np.flatnonzero(has)
    start = pts[rows, 8]
    d = pts[rows, corner[rows]] - start
    length = row_norms(d)
    cr = line_crossings(
        surface,
        start,
        d / length[:, None],
        SegmentSamples.uniform(length, 1),
        xatol=SHOT_ATOL * R,
    )
    first = np.r_[True, cr.segment[1:] != cr.segment[:-1]] if len(cr.segment) else []
    found = [cr.point[first]]
    # No sign change: Newton from the centre, kept if it lands on the surface
    # near its box.
    rows = np.flatnonzero(~has)
    if len(rows):
        x = pts[rows, 8]
        for _ in range(NEWTON_STEPS):
            fx = surface(x)
            g = surface.grad(x)
            gn = np.maximum(row_norms(g), TINY)
            x, _ = damped_step(x, -(fx / gn)[:, None] * (g / gn[:, None]), size)
        fx = surface(x)
        gn = row_norms(surface.grad(x))
        ok = (np.abs(fx) <= ON_SURFACE * R * gn) & (gn > 0)
        ok &= np.all(np.abs(x - pts[rows, 8]) <= size, axis=1)
        ok &= row_norms(x - surface.centre) < R
        found.append(x[ok])
    return np.concatenate(found)
