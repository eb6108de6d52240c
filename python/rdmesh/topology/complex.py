"""Combinatorics of the restricted complex: edge and vertex status, components.

Vectorised versions of CGAL's Complex_2_in_triangulation_3 queries: an edge is
boundary (1 facet), regular (2) or singular (3 or more); a vertex is regular
when its incident facets form one fan.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from .. import core
from .._mesh_components import component_euler, distinct_edges, labelled_components


@dataclass
class ComplexStatus:
    """Per-facet flags of non-manifold features.

    Attributes
    ----------
    edge_key : (E,) int64 key ``min * n + max`` of each distinct edge.
    edge_count : (E,) facets per edge.
    facet_edges : (F, 3) int32 index into ``edge_key`` of each facet's edges.
    vertex_fans : (n,) number of fans around each vertex (0 where it has no facet).
    """

    edge_key: np.ndarray
    edge_count: np.ndarray
    facet_edges: np.ndarray
    vertex_fans: np.ndarray

    def bad_edges(self, allow_boundary: bool) -> np.ndarray:
        """Indices of singular edges, plus boundary ones unless allowed."""
        return np.flatnonzero(failing_edges(self.edge_count, allow_boundary))


def complex_status(faces: np.ndarray, n_vertices: int) -> ComplexStatus:
    """Edge counts and fan counts of a triangle set.

    Parameters
    ----------
    faces : (F, 3) vertex ids.
    n_vertices : number of vertex ids.

    Raises
    ------
    ValueError
        If a face has an id outside ``[0, n_vertices)`` or repeats a vertex.
    """
    # In the core: linear time, and a third of the sort-and-components
    # version's time on the 288k facets of a grey-matter map (0.05 s).
    key, count, facet_edges, fans = core.complex_status(np.asarray(faces, np.int64), n_vertices)
    return ComplexStatus(key, count, facet_edges, fans)


def is_closed_manifold(faces: np.ndarray, n_vertices: int) -> bool:
    """Every edge in two faces and every used vertex with one fan of faces
    (False without faces, or with a face that repeats a vertex)."""
    if len(faces) == 0 or _degenerate(faces):
        return False
    st = complex_status(faces, n_vertices)
    used = np.unique(faces)
    return bool(np.all(st.edge_count == 2) and np.all(st.vertex_fans[used] == 1))


def is_manifold_with_boundary(faces: np.ndarray, n_vertices: int) -> bool:
    """Every edge in one or two faces, some in one (a boundary), and every
    used vertex with one fan of faces (False without faces, or with a face
    that repeats a vertex)."""
    if len(faces) == 0 or _degenerate(faces):
        return False
    st = complex_status(faces, n_vertices)
    used = np.unique(faces)
    return bool(
        np.all(st.edge_count <= 2)
        and np.any(st.edge_count == 1)
        and np.all(st.vertex_fans[used] == 1)
    )


def _degenerate(faces: np.ndarray) -> bool:
    """Whether some face repeats a vertex."""
    f = np.asarray(faces)
    return bool(np.any((f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 2] == f[:, 0])))


def failing_edges(edge_count: np.ndarray, allow_boundary: bool) -> np.ndarray:
    """(m,) bool: singular edges (3 or more facets), and boundary ones (1)
    unless allowed."""
    bad = edge_count >= 3
    if not allow_boundary:
        bad |= edge_count == 1
    return bad


def marked(n: int, ids: np.ndarray) -> np.ndarray:
    """(n,) bool, True at ``ids``: a lookup table, cheaper than ``np.isin``
    over every facet when the ids are many."""
    table = np.zeros(n, bool)
    table[ids] = True
    return table


def largest_per_group(
    group: np.ndarray, facet: np.ndarray, radius: np.ndarray, ties: tuple[np.ndarray, ...] = ()
) -> np.ndarray:
    """For each distinct value of ``group`` (ascending), the ``facet`` with the
    largest radius; among equal radii the one with the largest ``ties`` keys
    (per facet, the first compared first), else the last given.

    Parameters
    ----------
    group : (m,) group id of each incidence.
    facet : (m,) facet index of each incidence.
    radius : per-facet radii, indexed by ``facet``.
    ties : per-facet keys, indexed by ``facet``.
    """
    if group.size == 0:
        return np.zeros(0, np.int64)
    keys = tuple(t[facet] for t in reversed(ties))
    order = np.lexsort((*keys, radius[facet], group))
    g = group[order]
    last = np.r_[g[1:] != g[:-1], True]
    return facet[order][last]


def largest_incident(group: np.ndarray, facet: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """The distinct facets that :func:`largest_per_group` picks, ascending."""
    return np.unique(largest_per_group(group, facet, radius))


def component_topology(faces: np.ndarray, n_vertices: int) -> tuple[list[int], list[int]]:
    """:func:`euler_characteristics` and :func:`boundary_loops` at once: the
    components and edges are found once."""
    faces = np.asarray(faces, dtype=np.int64)
    count, face_label, vertex_label = labelled_components(faces, n_vertices)
    if count == 0:
        return [], []
    edge_key, edge_count = distinct_edges(faces, n_vertices)
    euler = component_euler(faces, face_label, count, n_vertices, vertex_label, edge_key)
    del face_label
    chi = [int(x) for x in euler]
    # Boundary loops: components of the graph of edges in one face.
    key = edge_key[edge_count == 1]
    del edge_key, edge_count
    if len(key) == 0:
        return chi, [0] * count
    a, b = key // n_vertices, key % n_vertices
    g = coo_matrix((np.ones(len(key)), (a, b)), shape=(n_vertices, n_vertices))
    _, vlabel = connected_components(g, directed=False)
    on = np.unique(np.concatenate([a, b]))
    # Each loop in the component of a face of one of its vertices.
    _, first = np.unique(vlabel[on], return_index=True)
    loops = np.bincount(vertex_label[on[first]], minlength=count)
    return chi, [int(x) for x in loops]


def euler_characteristics(faces: np.ndarray, n_vertices: int) -> list[int]:
    """Euler characteristic V - E + F of each component (in component order)."""
    return component_topology(faces, n_vertices)[0]


def boundary_loops(faces: np.ndarray, n_vertices: int) -> list[int]:
    """Number of boundary loops of each component (in component order).

    A boundary edge lies in exactly one face; the loops are the connected
    components of the graph of boundary edges (on a manifold with boundary
    every boundary vertex has two boundary edges, so each is a closed loop).
    """
    return component_topology(faces, n_vertices)[1]
