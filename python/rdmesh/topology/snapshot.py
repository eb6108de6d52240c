"""The restricted Delaunay triangulation at one moment, as the tests see it.

A :class:`Snapshot` is taken once per refinement round (and for the report).
Everything the stages and tests derive from the restricted facets (ball
radii, the complex's edge and fan counts, the KD-tree of the samples, the
normals at the samples, and each test's outcome) is computed at most once per
snapshot, so that stages asked one after the other, and a report on the last
round's samples, share the work.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
from scipy.spatial import cKDTree

from .. import core
from .._geometry import ball_radii
from ..sampling.probes import Probes, unit_normals
from ..surfaces.oracle import ImplicitSurface
from .complex import ComplexStatus, complex_status
from .defects import ComplexDefects
from .loops import LoopMemo
from .proven import proven_edge_test
from .proven_cells import (
    CellGeometry,
    CellProof,
    ProofMemo,
    prove_cells,
    proven_loop_test,
)
from .tests import (
    SILHOUETTE_ANGLE,
    Violations,
    disk_test,
    isolated_count,
    isolated_test,
    silhouette_test,
    voronoi_edge_test,
    voronoi_facet_test,
    voronoi_loop_test,
)


class Snapshot:
    """The samples and restricted facets of a core, with derived data computed once.

    Parameters
    ----------
    surface : ImplicitSurface
    rdt : the core (:class:`rdmesh.core.RestrictedDelaunay`); not changed.
    vertices : (n, 3) the samples, indexed by the core's vertex ids.
    memo : LoopMemo, optional
        Facets the loop test found clean in earlier rounds (kept across rounds).
    proofs : ProofMemo, optional
        Facets and cells the proven tests found clean in earlier rounds.
    weights : (n,) float, optional
        The vertices' weights (protecting balls); ball radii are then power radii.
    """

    def __init__(
        self,
        surface: ImplicitSurface,
        rdt: core.RestrictedDelaunay,
        vertices: np.ndarray,
        memo: LoopMemo | None = None,
        proofs: ProofMemo | None = None,
        weights: np.ndarray | None = None,
        defects: ComplexDefects | None = None,
    ) -> None:
        self.surface = surface
        self.rdt = rdt
        self.vertices = vertices
        #: The vertices' weights when some are protecting balls, else None.
        self.weights = weights
        self.memo = memo if memo is not None else LoopMemo()
        self.proofs = proofs
        #: The complex's failing edges and vertices kept across rounds, if any.
        self.defects = defects
        self._defects_ready = False
        self._facets: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self._radii: dict[int, np.ndarray] = {}
        self._tests: dict[tuple, Violations | None] = {}

    def facets(self, mask: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Restricted facets having any bit of ``mask`` (all when 0): ``(tri, centres, flags)``."""
        if mask not in self._facets:
            self._facets[mask] = self.rdt.facets(mask)
        return self._facets[mask]

    def radii(self, mask: int = 0) -> np.ndarray:
        """Surface Delaunay ball radii of :meth:`facets` ``(mask)``."""
        if mask not in self._radii:
            tri, centres, _ = self.facets(mask)
            self._radii[mask] = ball_radii(self.vertices, self.weights, tri, centres)
        return self._radii[mask]

    @cached_property
    def status(self) -> ComplexStatus:
        """Edge and fan counts of the restricted complex."""
        return complex_status(self.facets(0)[0], len(self.vertices))

    @cached_property
    def tree(self) -> cKDTree:
        """KD-tree of the samples: nearest sample = Voronoi cell membership."""
        return cKDTree(self.vertices)

    @cached_property
    def normals(self) -> np.ndarray:
        """Unit normals at the samples."""
        return unit_normals(self.surface, self.vertices)

    @cached_property
    def cells(self) -> CellGeometry:
        """Voronoi facets' boxes and the cells' neighbours (the proven tests)."""
        s = self.surface
        return CellGeometry.of(self.rdt, self.vertices, s.centre, s.radius)

    @cached_property
    def cell_proof(self) -> CellProof:
        """The silhouette proof of the restricted vertices' cells, whose leaves
        the loop proof starts from."""
        return prove_cells(
            self.surface, self.rdt, self.vertices, self.normals, self.cells, self.tree,
            np.unique(self.facets(0)[0]), self.proofs,
        )  # fmt: skip

    def test(
        self,
        kind: str,
        *,
        allow_boundary: bool = False,
        probes: Probes | None = None,
        angle: float = SILHOUETTE_ANGLE,
    ) -> Violations | None:
        """The outcome of one topology test (:mod:`rdmesh.topology.tests`).

        ``allow_boundary`` applies to ``voronoi_facet``; ``probes`` to
        ``voronoi_loop`` and ``silhouette``, ``angle`` to ``silhouette``.
        None when the test cannot run (silhouette without probes).
        """
        key = (
            kind,
            allow_boundary if kind == "voronoi_facet" else None,
            id(probes) if kind in ("voronoi_loop", "silhouette") else None,
            angle if kind == "silhouette" else None,
        )
        if key not in self._tests:
            self._tests[key] = self._run(kind, allow_boundary, probes, angle)
        return self._tests[key]

    def _from_defects(self, kind: str, allow_boundary: bool) -> Violations:
        """The edge or disk test from :attr:`defects`, brought up to date once."""
        _update_defects(self)
        return Violations(kind, *self.defects.failing(kind, allow_boundary))

    def _run(self, kind, allow_boundary, probes, angle) -> Violations | None:
        if kind in ("voronoi_facet", "disk") and self.defects is not None:
            return self._from_defects(kind, allow_boundary)
        tri, centres, flags = self.facets(0)
        if kind == "voronoi_edge":
            return voronoi_edge_test(tri, centres, self.radii(0), flags, core.TOPO)
        if kind == "voronoi_facet":
            return voronoi_facet_test(self.status, centres, self.radii(0), allow_boundary)
        if kind == "disk":
            return disk_test(self.status, tri, centres, self.radii(0))
        if kind == "voronoi_loop":
            return voronoi_loop_test(
                self.surface, self.rdt, self.vertices, tri, centres, self.status,
                probes, self.tree, self.memo,
            )  # fmt: skip
        if kind == "proven_voronoi_edge":
            return proven_edge_test(
                self.surface, self.rdt, self.vertices, tri, centres, self.cell_proof
            )
        if kind == "proven_voronoi_loop":
            return proven_loop_test(
                self.surface, self.vertices, self.cells, self.tree, tri, centres,
                self.proofs, self.rdt, self.cell_proof,
            )  # fmt: skip
        if kind == "proven_silhouette":
            return self.cell_proof.violations
        if kind == "isolated_count":
            return isolated_count(self.vertices, tri, self.weights)
        if kind == "isolated":
            return isolated_test(self.surface, self.vertices, tri, self.tree, self.weights)
        if kind == "silhouette":
            if probes is None:
                return None
            return silhouette_test(probes, self.vertices, self.normals, angle, self.tree)
        raise ValueError(f"unknown topology test {kind!r}")


def _update_defects(snap: Snapshot) -> None:
    if not snap._defects_ready:
        snap.defects.update(snap)
        snap._defects_ready = True


def confirm_defects(snap: Snapshot) -> bool:
    """Count every facet of ``snap`` for the edge and disk tests where counts
    around the changed samples gave them (before a run ends on them); True
    when that found defects those counts missed (the tests' outcomes are then
    computed again)."""
    if snap.defects is None:
        return False
    _update_defects(snap)
    if not snap.defects.confirm(snap):
        return False
    stale = ("voronoi_facet", "disk")
    snap._tests = {k: v for k, v in snap._tests.items() if k[0] not in stale}
    return True
