"""The samples: the core's vertices as one array, grown batch by batch."""

from __future__ import annotations

import numpy as np

from .. import core


class Samples:
    """The points inserted into the core, indexed by its vertex ids, with their
    weights (protecting balls: radius squared; samples: 0) and the number each
    stage inserted.

    Parameters
    ----------
    rdt : the core.
    """

    def __init__(self, rdt: core.RestrictedDelaunay) -> None:
        self.rdt = rdt
        self.points = np.zeros((0, 3))
        self.weights = np.zeros(0)
        self.inserted: dict[str, int] = {}
        #: The vertex ids of the last insertion's points (-1: hidden by a ball).
        self.last_ids = np.zeros(0, np.int64)

    @property
    def weighted(self) -> bool:
        """Whether any vertex is a protecting ball."""
        return bool(len(self.weights)) and bool(self.weights[0] > 0)

    def insert(self, points: np.ndarray, stage: str, weights: np.ndarray | None = None) -> int:
        """Insert ``(k, 3)`` points for ``stage``; returns how many were new samples.

        Points of weight 0 that the protecting balls hide are not inserted.
        """
        n0 = len(self.points)
        # A round's freed temporaries stay with malloc (two threads: two
        # arenas) and add up to the peak: 270 -> 227 MB at 89k samples on
        # the sphere.
        core.trim_heap()
        ids = self.rdt.insert(points, weights)
        self.last_ids = ids
        new = ids >= n0
        grown = np.empty((self.rdt.number_of_samples, 3))
        grown[:n0] = self.points
        grown[ids[new]] = points[new]
        self.points = grown
        w = np.zeros(len(grown))
        w[:n0] = self.weights
        if weights is not None:
            w[ids[new]] = np.asarray(weights, dtype=np.float64)[new]
        self.weights = w
        added = int(new.sum())
        self.inserted[stage] = self.inserted.get(stage, 0) + added
        return added

    def reload(self) -> None:
        """Take the samples from the core again (after an interrupted insertion)."""
        self.points = self.rdt.samples()
        self.weights = self.rdt.weights()
