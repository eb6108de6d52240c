"""Refinement stages, after CGAL's Mesher_level: each knows its elements, its
test and its refinement points.

A stage looks at a round's :class:`~rdmesh.topology.Snapshot` and returns
:class:`Candidates`: the centres and radii of the empty surface balls whose
centres would repair what it found, the number of elements that fail, and
whether the points are driven by the criteria or only by topology (which
decides the spacing floor they stop at). A method is an ordered list of
phases, each an ordered list of stages (:mod:`rdmesh.refine.methods`); the
mesher asks the stages of the current phase in order and inserts the points
of the first one that has any above the floor.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np

from .. import core
from ..sampling.probes import Probes
from ..topology import Snapshot


@dataclass
class Candidates:
    """Refinement points proposed by one stage.

    Attributes
    ----------
    stage : str
        The stage's name (progress, ``stats["inserted"]``).
    centres : (k, 3) centres of empty balls, on the surface.
    radii : (k,) their radii.
    topological : bool or (k,) bool
        True where a point is driven only by topology, not by the criteria:
        it stops at the topology floor rather than the numerical one.
    violations : int
        How many elements fail the stage's test.
    """

    stage: str
    centres: np.ndarray
    radii: np.ndarray
    topological: bool | np.ndarray
    violations: int = 0
    #: Where elements fail without a refinement point, ``(m, 3)``.
    stuck: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    #: ``(k,)`` bool, optional: points that may be dropped when they cannot be
    #: placed (facets bad only by the angle bound at the boundary).
    soft: np.ndarray | None = None

    #: ``(k,)`` the stage of each point when several stages' points were
    #: joined (:meth:`join`), else None (all are ``stage``'s).
    origin: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.centres)

    def stages(self, pick: np.ndarray) -> np.ndarray:
        """``(len(pick),)`` the stage name of each picked point."""
        if self.origin is None:
            return np.full(len(pick), self.stage, dtype=object)
        return self.origin[pick]

    @staticmethod
    def join(parts: list[Candidates]) -> Candidates:
        """One set of points from several stages' (named by the first stage;
        :meth:`stages` tells each point's own)."""
        if len(parts) == 1:
            return parts[0]
        soft = None
        if any(c.soft is not None for c in parts):
            soft = np.concatenate(
                [c.soft if c.soft is not None else np.zeros(len(c), bool) for c in parts]
            )
        return Candidates(
            parts[0].stage,
            np.concatenate([c.centres for c in parts]),
            np.concatenate([c.radii for c in parts]),
            np.concatenate([np.broadcast_to(c.topological, len(c)) for c in parts]),
            sum(c.violations for c in parts),
            soft=soft,
            origin=np.concatenate([c.stages(np.arange(len(c))) for c in parts]),
        )

    def take(self, keep: np.ndarray) -> Candidates:
        """The candidates where ``keep`` is True (``stage``, ``violations`` and
        ``stuck`` are not per point: they stay)."""
        topo = np.broadcast_to(self.topological, len(self.centres))[keep]
        soft = None if self.soft is None else self.soft[keep]
        origin = None if self.origin is None else self.origin[keep]
        return replace(
            self, centres=self.centres[keep], radii=self.radii[keep], topological=topo, soft=soft,
            origin=origin,
        )  # fmt: skip


class Stage(Protocol):
    """One level of refinement."""

    name: str

    def candidates(self, snap: Snapshot) -> Candidates:
        """The points this stage would insert on the snapshot's samples."""
        ...


@dataclass(frozen=True)
class FacetStage:
    """Restricted facets carrying any of the core's flag bits ``mask``.

    ``topological`` says which facets are driven only by topology: all
    (True), none (False), or those without the ``BAD`` flag (``"unless-bad"``:
    a facet both bad by the criteria and crossed badly is criteria-driven).
    """

    name: str
    mask: int
    topological: bool | str
    #: Which facets are optional, given ``(corners (k, 3, 3), centres, radii,
    #: flags)``: see :attr:`Candidates.soft`.
    soft: Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None

    def candidates(self, snap: Snapshot) -> Candidates:
        tri, centres, flags = snap.facets(self.mask)
        radii = snap.radii(self.mask)
        topo = self.topological
        if topo == "unless-bad":
            topo = (flags & core.BAD) == 0
        soft = None
        if self.soft is not None:
            soft = self.soft(snap.vertices[tri], centres, radii, flags)
        return Candidates(self.name, centres, radii, topo, len(centres), soft=soft)


@dataclass(frozen=True)
class TestStage:
    """A topology test (:mod:`rdmesh.topology.tests`); its points are topology-driven."""

    name: str
    test: str
    allow_boundary: bool = False
    probes: Probes | None = None
    angle: float = 90.0
    #: Asked only when no earlier stage left anything unresolved (a proof
    #: cannot certify a run that is incomplete anyway, and costs a full pass).
    only_if_clean: bool = False

    def candidates(self, snap: Snapshot) -> Candidates:
        v = snap.test(self.test, allow_boundary=self.allow_boundary, probes=self.probes,
                      angle=self.angle)  # fmt: skip
        if v is None:
            return Candidates(self.name, np.zeros((0, 3)), np.zeros(0), True)
        return Candidates(self.name, v.centres, v.radii, True, v.count, v.stuck)
