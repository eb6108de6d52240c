"""A method's phases of stages, asked in order (CGAL's Mesher_level chain)."""

from __future__ import annotations

import logging

import numpy as np

from ..topology import Snapshot
from .floor import SpacingFloor
from .stages import Candidates, Stage

log = logging.getLogger("rdmesh")


class Phases:
    """Ordered phases, each an ordered list of stages; remembers the current phase.

    A phase whose stages are all satisfied gives way to the next one for good.
    """

    def __init__(self, phases: list[list[Stage]], floor: SpacingFloor) -> None:
        self.phases = phases
        self.floor = floor
        self.current = 0

    def ask(self, snap: Snapshot) -> tuple[Candidates | None, list[np.ndarray]]:
        """The points of the first stage, in phase order, that has any above the
        floor (None when every stage of the last phase is satisfied), and the
        unresolved points met on the way: below the floor, or failing
        elements without a refinement point."""
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
                if keep.any():
                    return cand.take(keep), unresolved
            if self.current + 1 == len(self.phases):
                return None, unresolved
            self.current += 1
            log.debug("phase %d begins at %d samples", self.current, len(snap.vertices))
