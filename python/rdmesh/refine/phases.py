"""A method's phases of stages, asked in order (CGAL's Mesher_level chain)."""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

from ..topology import Snapshot
from .floor import SpacingFloor
from .stages import Candidates, Stage

log = logging.getLogger("rdmesh")


class Phases:
    """Ordered phases, each an ordered list of stages; remembers the current phase.

    A phase whose stages are all satisfied gives way to the next one for good.
    """

    def __init__(
        self,
        phases: list[list[Stage]],
        floor: SpacingFloor,
        place: Callable[[Candidates, Snapshot], tuple[Candidates, np.ndarray]] | None = None,
    ) -> None:
        self.phases = phases
        self.floor = floor
        #: Moves or drops a stage's points before they count (the boundary
        #: guard of a clipped surface); returns the kept points and the
        #: refused ones (unresolved).
        self.place = place
        self.current = 0

    def ask(self, snap: Snapshot) -> tuple[Candidates | None, list[np.ndarray]]:
        """The points of the first stage, in phase order, that has any above the
        floor and left by ``place`` (None when every stage of the last phase
        is satisfied), and the unresolved points met on the way: below the
        floor, refused by ``place``, or failing elements without a
        refinement point."""
        unresolved = []
        while True:
            for stage in self.phases[self.current]:
                if getattr(stage, "only_if_clean", False) and unresolved:
                    continue
                cand = stage.candidates(snap)
                if len(cand.stuck):
                    unresolved.append(cand.stuck)
                if len(cand) == 0:
                    continue
                keep = self.floor.keep(cand)
                if not keep.all():
                    unresolved.append(cand.centres[~keep])
                if not keep.any():
                    continue
                cand = cand.take(keep)
                if self.place is not None:
                    cand, refused = self.place(cand, snap)
                    if len(refused):
                        unresolved.append(refused)
                if len(cand):
                    return cand, unresolved
            if self.current + 1 == len(self.phases):
                return None, unresolved
            self.current += 1
            log.debug("phase %d begins at %d samples", self.current, len(snap.vertices))
