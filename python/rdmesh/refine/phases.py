"""A method's phases of stages, asked in order (CGAL's Mesher_level chain)."""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

from ..topology import Snapshot
from .floor import SpacingFloor
from .stages import Candidates, Stage

log = logging.getLogger("rdmesh")

#: Stages whose points join a round whose first stage offers few points
#: (fewer than JOIN_BELOW): the complex's edge and vertex repairs. Asked only
#: after the facet stage, they waited behind a tail of rounds of 1 to 8
#: skinny facets each (the linear MNI152 grey-matter map reached the cap of
#: 2,000 rounds; joined, it ended at 449; benchmarks/RESULTS.md).
JOINED = ("edge", "vertex")
JOIN_BELOW = 64


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
        refinement point.

        When that stage offers fewer than :data:`JOIN_BELOW` points, the
        points of the later :data:`JOINED` stages of the phase join them.
        """
        unresolved: list[np.ndarray] = []
        while True:
            stages = self.phases[self.current]
            for i, stage in enumerate(stages):
                cand = self._points(stage, snap, unresolved)
                if cand is None:
                    continue
                parts = [cand]
                for later in stages[i + 1 :]:
                    if sum(map(len, parts)) >= JOIN_BELOW:
                        break
                    if later.name in JOINED:
                        more = self._points(later, snap, unresolved)
                        if more is not None:
                            parts.append(more)
                return Candidates.join(parts), unresolved
            if self.current + 1 == len(self.phases):
                return None, unresolved
            self.current += 1
            log.debug("phase %d begins at %d samples", self.current, len(snap.vertices))

    def _points(self, stage: Stage, snap: Snapshot, unresolved: list) -> Candidates | None:
        """``stage``'s points above the floor and left by ``place``, or None;
        the others go to ``unresolved``."""
        if getattr(stage, "only_if_clean", False) and unresolved:
            return None
        if hasattr(stage, "unresolved"):  # the distance check keeps clear of them
            stage.unresolved = np.concatenate(unresolved) if unresolved else np.zeros((0, 3))
        cand = stage.candidates(snap)
        if len(cand.stuck):
            unresolved.append(cand.stuck)
        if len(cand) == 0:
            return None
        keep = self.floor.keep(cand)
        if not keep.all():
            unresolved.append(cand.centres[~keep])
        if not keep.any():
            return None
        cand = cand.take(keep)
        if self.place is not None:
            cand, refused = self.place(cand, snap)
            if len(refused):
                unresolved.append(refused)
        return cand if len(cand) else None
