"""The samples: the core's vertices as one array, grown batch by batch."""

from __future__ import annotations

import numpy as np

from .. import core


class Samples:
    """The points inserted into the core, indexed by its vertex ids, with the
    number each stage inserted.

    Parameters
    ----------
    rdt : the core.
    """

    def __init__(self, rdt: core.RestrictedDelaunay) -> None:
        self.rdt = rdt
        self.points = np.zeros((0, 3))
        self.inserted: dict[str, int] = {}

    def insert(self, points: np.ndarray, stage: str) -> int:
        """Insert ``(k, 3)`` points for ``stage``; returns how many were new samples."""
        n0 = len(self.points)
        # A round's freed temporaries stay with malloc (two threads: two
        # arenas) and add up to the peak: 270 -> 227 MB at 89k samples on
        # the sphere.
        core.trim_heap()
        ids = self.rdt.insert(points)
        new = ids >= n0
        grown = np.empty((self.rdt.number_of_samples, 3))
        grown[:n0] = self.points
        grown[ids[new]] = points[new]
        self.points = grown
        added = int(new.sum())
        self.inserted[stage] = self.inserted.get(stage, 0) + added
        return added

    def reload(self) -> None:
        """Take the samples from the core again (after an interrupted insertion)."""
        self.points = self.rdt.samples()
