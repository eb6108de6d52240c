"""Connected components of a triangle set, shared by the topology report and the
mesh input (which must not import :mod:`rdmesh.topology`)."""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components


def components(faces: np.ndarray, n_vertices: int) -> tuple[int, np.ndarray]:
    """Connected components of a triangle set (facets sharing a vertex).

    Returns
    -------
    count : int
    face_label : (F,) component of each face, numbered by first face.
    """
    count, face_label, _ = labelled_components(np.asarray(faces, dtype=np.int64), n_vertices)
    return count, face_label


def labelled_components(faces: np.ndarray, n_vertices: int) -> tuple[int, np.ndarray, np.ndarray]:
    """:func:`components`, and the component of each vertex (-1 where it has no face).

    The graph joins each face's first vertex to the other two: its nodes are
    the vertices, not the faces and vertices, so that it stays small (it sets
    the peak memory of the final report).
    """
    F = len(faces)
    if F == 0:
        return 0, np.zeros(0, np.int64), np.full(n_vertices, -1, np.int64)
    rows = np.empty(2 * F, np.int32)
    cols = np.empty(2 * F, np.int32)
    rows[:F] = rows[F:] = faces[:, 0]
    cols[:F], cols[F:] = faces[:, 1], faces[:, 2]
    g = coo_matrix((np.ones(2 * F, bool), (rows, cols)), shape=(n_vertices, n_vertices))
    del rows, cols
    k, label = connected_components(g, directed=False)
    del g
    # Renumber by first face, for stable output.
    face_raw = label[faces[:, 0]]
    raw, first = np.unique(face_raw, return_index=True)
    rank = np.full(k, -1, np.int64)
    rank[raw] = np.argsort(np.argsort(first))
    return len(raw), rank[face_raw], rank[label]


def distinct_edges(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """The distinct edges of a triangle set, by sorted key ``min * n + max``,
    and the faces of each edge."""
    F = len(faces)
    keys = np.empty(3 * F, np.int64)
    for j in range(3):
        u, v, out = faces[:, j], faces[:, (j + 1) % 3], keys[j * F : (j + 1) * F]
        # The key min * n + max written in place: one temporary per column.
        np.minimum(u, v, out=out)
        out *= n_vertices
        out += np.maximum(u, v)
    keys.sort()
    first = np.empty(len(keys), bool)
    first[:1] = True
    np.not_equal(keys[1:], keys[:-1], out=first[1:])
    start = np.flatnonzero(first)
    del first
    return keys[start], np.diff(start, append=len(keys))


def component_euler(
    faces: np.ndarray,
    face_label: np.ndarray,
    count: int,
    n_vertices: int,
    vertex_label: np.ndarray | None = None,
    edge_key: np.ndarray | None = None,
) -> np.ndarray:
    """``(count,)`` ``V - E + F`` of the faces of each label (components, or
    components of a superset of ``faces``). A vertex or an edge counts in the
    label of any face that has it. ``vertex_label`` and ``edge_key``
    (:func:`distinct_edges`) are found when not given."""
    faces = np.asarray(faces, np.int64)
    if vertex_label is None:
        vertex_label = np.full(n_vertices, -1, np.int64)
        vertex_label[faces.reshape(-1)] = np.repeat(face_label, 3)
    if edge_key is None:
        edge_key, _ = distinct_edges(faces, n_vertices)
    nv = np.bincount(vertex_label[vertex_label >= 0], minlength=count)
    ne = np.bincount(vertex_label[edge_key // n_vertices], minlength=count)
    return nv - ne + np.bincount(face_label, minlength=count)
