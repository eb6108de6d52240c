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
        self.points = self._points = np.zeros((0, 3))
        self.weights = self._weights = np.zeros(0)
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
        if len(points) >= TRIM_SHARE * n0:
            # A round's freed temporaries stay with malloc (two threads: two
            # arenas) and add up to the peak: 270 -> 227 MB at 89k samples
            # on the sphere. A round that adds a few points adds little.
            core.trim_heap()
        ids = self.rdt.insert(points, weights)
        self.last_ids = ids
        new = ids >= n0
        n = self.rdt.number_of_samples
        if n > len(self._points):
            # Room to grow by half: rounds that add a few points to a large
            # sample do not copy it each time.
            self._points = _grown(self._points, n0, (n + n // 2, 3))
            self._weights = _grown(self._weights, n0, (n + n // 2,))
        self._points[ids[new]] = points[new]
        self._weights[n0:n] = 0.0
        if weights is not None:
            self._weights[ids[new]] = np.asarray(weights, dtype=np.float64)[new]
        # Views: rows below n0 never change, so earlier views stay valid.
        self.points, self.weights = self._points[:n], self._weights[:n]
        added = int(new.sum())
        self.inserted[stage] = self.inserted.get(stage, 0) + added
        return added

    def reload(self) -> None:
        """Take the samples from the core again (after an interrupted insertion)."""
        self.points = self._points = self.rdt.samples()
        self.weights = self._weights = self.rdt.weights()


#: Batches of at least this share of the samples return freed memory first.
TRIM_SHARE = 0.01


def _grown(a: np.ndarray, keep: int, shape: tuple[int, ...]) -> np.ndarray:
    """A new array of ``shape`` holding the first ``keep`` rows of ``a``."""
    out = np.empty(shape)
    out[:keep] = a[:keep]
    return out
