"""A finer clearing level where the seeding grid clears too little (issue 30).

The core clears a dual segment by the grid node nearest its middle when
``|f|`` there exceeds the slope bound times the node's distance to the
segment (:func:`rdmesh.sampling.screen.clear_in_core`). Near the core of a
thin part that fails: ``|f|`` is small there (the thin torus's tube, radius
0.1, against a grid spacing of 0.047) and the coarse bound takes in the
steep slopes at the surface, so the many Voronoi vertices that gather about
the part's medial axis are all evaluated.

The core counts, per grid node, the segments nothing cleared near it; a node
becomes *hot* at its ``HOT_MISSES``-th. Between chunks (the core's worker is
idle then) :meth:`FineClearing.refine` evaluates ``f`` at the centres of the
``SUBDIVISIONS``^3 subcubes of each hot node's cube, in one call, and hands
the values to the core with a bound on ``|grad f|`` there: the surface's
proven one; else a proven one for the cube where the surface has one
(``surface.gradient_bound(centres, radius)``: a volume's, from its
coefficients; cubes where it is over ``WORTH`` times the grid's estimate
are not filled); else ``SAFETY`` times the steepest slope seen between
those centres and along the node's own grid edges (an estimate, like the
coarse level's; on the cubic MNI152 grey-matter map it was too low and the
mesh lost its closedness). A filled cube clears segments up to
``FINE_REACH`` grid spacings long by the subcube centre nearest their
middle, as the coarse level does.

On the thin torus at about 100k vertices, counting the segments of a run
offline, 490 hot nodes (0.3 evaluations per vertex) clear segments whose 14
new ends per vertex would otherwise each cost an evaluation."""

from __future__ import annotations

import numpy as np

from .. import core
from .screen import SAFETY, SlopeBound

#: A hot node's cube is cut into this many subcubes per axis.
SUBDIVISIONS = 4
#: A node becomes hot at this many uncleared segments near it (each filled
#: cube costs ``SUBDIVISIONS**3`` evaluations).
HOT_MISSES = 256
#: A filled cube clears segments up to this many grid spacings long (its
#: bound covers the cube and half that about it).
FINE_REACH = 0.5
#: Half-side, in grid spacings, of the axis-aligned box about a node that a
#: local proven bound covers: the node's cube, possibly rotated (sqrt(3) / 2),
#: and half a segment of FINE_REACH beyond it (0.25), rounded up.
CUBE_REACH = 1.2
#: A cube with a local proven bound is filled only where that bound is at most
#: this many times the grid's estimate at its node (SAFETY x its slopes).
WORTH = 2.0


class FineClearing:
    """Fills the core's fine clearing level at the nodes it reports hot.

    Parameters
    ----------
    rdt : the core, after ``set_clearing`` from ``bound``'s field.
    surface : the oracle; ``surface(points)`` gives ``f``.
    bound : the slope bound whose field the core clears by.
    """

    def __init__(self, rdt: core.RestrictedDelaunay, surface, bound: SlopeBound) -> None:
        field = bound.field
        self.rdt, self.surface, self.bound = rdt, surface, bound
        self.h = field.h
        rdt.set_fine_clearing(SUBDIVISIONS, HOT_MISSES, FINE_REACH * field.h)

    def refine(self) -> int:
        """Fill the cubes of the nodes that became hot; how many. Call only
        while the core's worker is idle."""
        nodes = self.rdt.take_hot_nodes()
        if not len(nodes):
            return 0
        points = self.rdt.fine_points(nodes)
        local = self._local_bounds(nodes, points)
        if local is not None:
            # A cube whose proven bound is far above the grid's estimate there
            # would clear too little to pay for its evaluations: left unfilled.
            worth = local <= WORTH * SAFETY * self.bound.field.node_slopes[nodes]
            nodes, local = nodes[worth], local[worth]
            points = points.reshape(len(worth), -1, 3)[worth].reshape(-1, 3)
            if not len(nodes):
                return 0
        values = np.asarray(self.surface(points), dtype=float)
        values = np.where(np.isfinite(values), values, np.nan)
        bounds = local if local is not None else self._bounds(nodes, values)
        self.rdt.fill_fine(nodes, values, bounds)
        return len(nodes)

    def _local_bounds(self, nodes: np.ndarray, points: np.ndarray) -> np.ndarray | None:
        """The surface's proven bound for each node's box, where it gives one
        (``gradient_bound``) and has no proven global one; else None."""
        local = getattr(self.surface, "gradient_bound", None)
        if self.bound.proven or local is None:
            return None
        centres = points.reshape(len(nodes), -1, 3).mean(axis=1)
        return np.asarray(local(centres, CUBE_REACH * self.h), dtype=float)

    def _bounds(self, nodes: np.ndarray, values: np.ndarray) -> np.ndarray:
        """A bound on ``|grad f|`` per filled cube (module docstring)."""
        if self.bound.proven:
            return np.full(len(nodes), self.bound.value)
        m = SUBDIVISIONS
        cubes = values.reshape(len(nodes), m, m, m)
        slope = np.zeros(len(nodes))
        for axis in (1, 2, 3):
            d = np.abs(np.diff(cubes, axis=axis)).reshape(len(nodes), -1)
            # NaN anywhere: NaN, and the core takes its cap (the global bound).
            slope = np.hypot(slope, d.max(axis=1) * (m / self.h))
        slope = np.maximum(slope, self.bound.field.node_slopes[nodes])
        return SAFETY * slope


def fine_clearing(rdt: core.RestrictedDelaunay, surface, bound: SlopeBound | None):
    """A :class:`FineClearing` when the core clears by a grid, else None."""
    if bound is None or bound.field is None:
        return None
    return FineClearing(rdt, surface, bound)
