"""The spacing floor: refinement points too close to the samples are refused.

Criteria-driven points stop at a numerical floor; points driven only by
topology stop at a fraction of the size bound (or, without one, at a
fraction of the bounding radius), so that refinement ends near singular
points (algorithm.md 7.1). Refused points are reported as unresolved.
"""

from __future__ import annotations

import numpy as np

from .._tol import MIN_SPACING, TOPOLOGY_FLOOR
from .criteria import FacetCriteria
from .stages import Candidates


class SpacingFloor:
    """Decides which candidates are far enough from the samples to insert.

    Parameters
    ----------
    criteria : FacetCriteria
        Its sizing field sets the topology floor where there is one.
    radius : the bounding radius R.
    topology_floor : float
        The floor of topology-driven points when there is no sizing field.
    """

    def __init__(self, criteria: FacetCriteria, radius: float, topology_floor: float) -> None:
        self.criteria = criteria
        self.h_min = MIN_SPACING * radius
        self.topology_floor = topology_floor

    def keep(self, cand: Candidates) -> np.ndarray:
        """(k,) bool: the candidates whose ball radius is above their floor."""
        centres = cand.centres
        floor = np.full(len(centres), self.h_min)
        topo = np.broadcast_to(cand.topological, len(centres))
        if topo.any():
            floor[topo] = self.topology(centres[topo])
        return cand.radii > floor

    def topology(self, centres: np.ndarray) -> np.ndarray:
        """(k,) the floor of topology-driven points at ``centres``."""
        psi = self.criteria.sizing(centres)
        if psi is None:
            return np.full(len(centres), self.topology_floor)
        return np.maximum(self.h_min, TOPOLOGY_FLOOR * psi)
