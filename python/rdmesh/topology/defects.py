"""The restricted complex's defects, kept from round to round.

The edge test (T2: edges in other than two restricted facets) and the disk
test (T3: vertices whose facets form more than one fan) need the edge and fan
counts of the whole complex, which cost a pass over every restricted facet
(0.2 s at 288k facets). Late rounds of a large run insert a few points each,
so :class:`ComplexDefects` keeps the failing edges and vertices, each with
its largest incident facet, and each round recounts only around the samples
whose restricted facets may have changed (the core's touched vertices: those
of every cell made since). An edge or vertex away from them has the same
facets as before, so its entry stands. When the touched samples are many,
every facet is counted again, and :meth:`ComplexDefects.confirm` counts every
facet before a run ends on a clean complex (until then a local count that
finds nothing is not confirmed: a run with few points per round would pay a
whole count each round).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._errors import InternalCheckError
from .._geometry import ball_radii
from .complex import complex_status, failing_edges, largest_per_group, marked

#: Above this share of touched samples, every facet is counted again.
FULL_SHARE = 0.05


@dataclass
class DefectTable:
    """Failing elements, sorted by id, with their largest incident facet.

    Attributes
    ----------
    ids : (m, 2) edge ends (smaller first) or (m, 1) vertex ids.
    count : (m,) facets per edge, or fans per vertex.
    facet : (m, 3) sorted vertex ids of the largest incident facet.
    centre : (m, 3) its surface centre.
    radius : (m,) its ball radius (power radius with protecting balls).
    """

    ids: np.ndarray
    count: np.ndarray
    facet: np.ndarray
    centre: np.ndarray
    radius: np.ndarray

    def take(self, rows: np.ndarray) -> DefectTable:
        return DefectTable(*(a[rows] for a in self._columns()))

    def _columns(self) -> tuple[np.ndarray, ...]:
        return self.ids, self.count, self.facet, self.centre, self.radius

    def picks(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Centres and radii of the distinct largest facets of ``rows`` (by
        facet, ascending)."""
        _, first = np.unique(self.facet[rows], axis=0, return_index=True)
        chosen = np.flatnonzero(rows)[first] if rows.dtype == bool else rows[first]
        return self.centre[chosen], self.radius[chosen]


class ComplexDefects:
    """Failing edges and vertices of the restricted complex, updated incrementally.

    Parameters
    ----------
    check : recount everything each update and compare (``RDMESH_CHECK=1``).
    """

    def __init__(self, check: bool = False) -> None:
        self.check = check
        self.edges: DefectTable | None = None
        self.vertices: DefectTable | None = None
        #: Updates that counted every facet, and those that counted locally.
        self.full_counts = 0
        self.local_counts = 0
        #: Whether the tables come from a count of every facet of the current
        #: complex (no local count since).
        self.confirmed = False

    def update(self, snap) -> None:
        """Bring the tables to the snapshot's complex (once per snapshot)."""
        rdt = snap.rdt
        touched = rdt.take_touched()
        n = len(snap.vertices)
        if self.edges is None or len(touched) > FULL_SHARE * n:
            self._full(snap)
            return
        if not len(touched):
            return  # nothing changed
        self.local_counts += 1
        self.confirmed = False
        tri, centres, _ = rdt.facets_around(touched)
        near = np.zeros(n, bool)
        near[touched] = True
        radii = ball_radii(snap.vertices, snap.weights, tri, centres)
        edges, vertices = _tables(tri, centres, radii, n, near)
        old_e, old_v = self.edges, self.vertices
        keep_e = ~(near[old_e.ids[:, 0]] | near[old_e.ids[:, 1]])
        self.edges = _merged(old_e.take(keep_e), edges)
        self.vertices = _merged(old_v.take(~near[old_v.ids[:, 0]]), vertices)
        if self.check:
            local = (self.edges, self.vertices)
            self._full(snap)
            _compare(local, (self.edges, self.vertices))

    def confirm(self, snap) -> bool:
        """Count every facet of ``snap`` (brought up to date by :meth:`update`)
        unless the tables already come from such a count; True when the
        count changed them (local counts missed something)."""
        if self.confirmed or self.edges is None:
            return False
        local = (self.edges, self.vertices)
        self._full(snap)
        return not all(map(_same, local, (self.edges, self.vertices)))

    def _full(self, snap) -> None:
        self.full_counts += 1
        self.confirmed = True
        tri, centres, _ = snap.facets(0)
        self.edges, self.vertices = _tables(
            tri, centres, snap.radii(0), len(snap.vertices), None, snap.status
        )

    def edge_rows(self, allow_boundary: bool) -> np.ndarray:
        """(m,) bool: the edges failing T2 (in one facet counts unless allowed)."""
        return failing_edges(self.edges.count, allow_boundary)

    def failing(self, kind: str, allow_boundary: bool) -> tuple[int, np.ndarray, np.ndarray]:
        """The edge ("voronoi_facet") or disk test's violation count, and the
        centres and radii of the distinct largest facets at the violations."""
        if kind == "voronoi_facet":
            table, rows = self.edges, self.edge_rows(allow_boundary)
        else:
            table, rows = self.vertices, np.ones(len(self.vertices.ids), bool)
        return (int(rows.sum()), *table.picks(rows))


def _tables(tri, centres, radii, n, near, status=None) -> tuple[DefectTable, DefectTable]:
    """Failing edges and vertices of the facets ``tri``; with ``near`` only
    those with a vertex where it is True (the facets hold all of theirs)."""
    tri = np.asarray(tri, np.int64)
    st = complex_status(tri, n) if status is None else status
    lo, hi = st.edge_key // n, st.edge_key % n
    bad_e = failing_edges(st.edge_count, allow_boundary=False)
    if near is not None:
        bad_e &= near[lo] | near[hi]
    e = np.flatnonzero(bad_e)
    f_e, slot = np.nonzero(marked(len(st.edge_key), e)[st.facet_edges])
    sorted_tri = np.sort(tri, axis=1)
    ties = tuple(sorted_tri.T)  # not the facets' order
    edge_pick = largest_per_group(st.facet_edges[f_e, slot], f_e, radii, ties)
    bad_v = st.vertex_fans > 1
    if near is not None:
        bad_v &= near
    v = np.flatnonzero(bad_v)
    f_v, corner = np.nonzero(marked(n, v)[tri])
    vertex_pick = largest_per_group(tri[f_v, corner], f_v, radii, ties)
    edges = DefectTable(
        np.column_stack([lo[e], hi[e]]), st.edge_count[e], sorted_tri[edge_pick],
        centres[edge_pick], radii[edge_pick],
    )  # fmt: skip
    vertices = DefectTable(
        v[:, None], st.vertex_fans[v], sorted_tri[vertex_pick], centres[vertex_pick],
        radii[vertex_pick],
    )  # fmt: skip
    return edges, vertices


def _merged(kept: DefectTable, new: DefectTable) -> DefectTable:
    """The rows of both, sorted by id."""
    cols = zip(kept._columns(), new._columns(), strict=True)
    cat = DefectTable(*(np.concatenate([a, b]) for a, b in cols))
    order = np.lexsort(cat.ids.T[::-1])
    return cat.take(order)


def _same(a: DefectTable, b: DefectTable) -> bool:
    return all(np.array_equal(x, y) for x, y in zip(a._columns(), b._columns(), strict=True))


def _compare(local, full) -> None:
    for name, a, b in zip(("edge", "vertex"), local, full, strict=True):
        if not _same(a, b):
            raise InternalCheckError(
                f"the {name} defects counted around the touched samples differ from a "
                f"count over every facet ({len(a.ids)} against {len(b.ids)} rows)"
            )
