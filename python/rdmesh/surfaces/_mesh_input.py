"""The input of :class:`~rdmesh.MeshSurface`: checking, cleaning and orienting a
triangle mesh, and what can be told about it before meshing.

A mesh is read as ``(vertices, faces)`` (:func:`as_arrays`), its equal vertices
merged, degenerate and repeated faces dropped, faces turned to agree with their
neighbours (:mod:`._mesh_repair`) and pinched vertices split (:func:`clean`), and
oriented so that its signed volume is positive (:func:`oriented_mesh`). Then:
its bounding sphere, its folds (:func:`fold_edges`), whether the C++ side test
applies (:func:`is_closed_oriented`), how ambiguous the winding number is next
to it (:func:`winding_ambiguity`), and which way its face normals point
(:func:`orient_normals`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from .._errors import MeshInputError
from .._validate import scale_problem
from .._vectors import unique_rows
from ..core import MeshDistance
from ..features.sharp_edges import sharp_edges
from ._mesh_repair import check_volumes, coherently_oriented, without_duplicates

log = logging.getLogger("rdmesh")

#: The bounding sphere's radius, times the largest distance of a vertex from
#: the centre of the mesh's bounding box.
SPHERE_MARGIN = 1.2
#: A face is ambiguous when the winding number just outside it is farther
#: than this from a whole number ...
AMBIGUOUS_MARGIN = 0.25
#: ... and an open mesh is refused when ambiguous faces hold more than this
#: share of its area.
MAX_AMBIGUOUS_SHARE = 0.2
#: Faces sampled for that check (a fixed, seeded subset of larger meshes).
AMBIGUITY_SAMPLES = 20_000
#: Two faces sharing an edge whose normals differ by more than this (degrees)
#: form a fold: a razor-thin wedge with no feature size (logged as a warning).
FOLD_ANGLE = 150.0


def as_arrays(mesh: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(vertices (n, 3) float64, faces (m, 3) int64)`` of a mesh, checked."""
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        vertices, faces = mesh.vertices, mesh.faces
    elif isinstance(mesh, (tuple, list)) and len(mesh) == 2:
        vertices, faces = mesh
    else:
        raise MeshInputError(
            "mesh must be a trimesh.Trimesh or a (vertices, faces) pair, "
            f"got {type(mesh).__name__}"
        )
    if np.iscomplexobj(vertices):
        raise MeshInputError("mesh vertices must be real numbers, got complex values")
    try:
        v = np.array(vertices, dtype=np.float64)
    except (TypeError, ValueError):
        raise MeshInputError("mesh vertices must be an (n, 3) array of numbers") from None
    f_in = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3:
        raise MeshInputError(f"mesh vertices must have shape (n, 3), got {v.shape}")
    if f_in.ndim != 2 or f_in.shape[1] != 3:
        raise MeshInputError(f"mesh faces must have shape (m, 3) (triangles), got {f_in.shape}")
    if len(v) == 0 or len(f_in) == 0:
        raise MeshInputError(
            f"the mesh is empty ({len(v)} vertices, {len(f_in)} faces); it needs triangles"
        )
    bad = ~np.isfinite(v)
    if bad.any():
        i = int(np.argmax(bad.any(axis=1)))
        raise MeshInputError(
            f"mesh vertex {i} is not finite: {v[i].tolist()} "
            f"({int(bad.any(axis=1).sum())} non-finite vertices)"
        )
    integral = f_in.dtype.kind in "iu" or (
        f_in.dtype.kind == "f" and np.all(np.isfinite(f_in)) and np.all(f_in == np.round(f_in))
    )
    if not integral:
        raise MeshInputError(f"mesh faces must be integer vertex indices, got {f_in.dtype}")
    f = f_in.astype(np.int64)
    out = (f < 0) | (f >= len(v))
    if out.any():
        i = int(np.argmax(out.any(axis=1)))
        raise MeshInputError(
            f"mesh face {i} refers to vertex {int(f[i][out[i]][0])}, out of range "
            f"for {len(v)} vertices"
        )
    return v, f


def clean(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge equal vertices, drop faces that repeat a vertex, repeated faces and
    unused vertices, turn faces to agree with their neighbours, and split
    pinched vertices (:func:`split_pinches`)."""
    v, inverse = unique_rows(v)
    f = inverse[f]
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    f = f[keep]
    if len(f) == 0:
        raise MeshInputError("every face of the mesh has zero area (repeated vertices)")
    f = coherently_oriented(without_duplicates(f))
    if len(f) == 0:
        raise MeshInputError("every face of the mesh is listed once each way: they cancel out")
    used, f = np.unique(f, return_inverse=True)
    return split_pinches(v[used], f.reshape(-1, 3).astype(np.int64))


def split_pinches(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Give each fan of faces about a pinched vertex its own copy of the vertex.

    A vertex is pinched when its faces form more than one fan (faces joined
    through the edges at the vertex), as where merging equal vertices joined
    two sheets at a point (CGAL's ``duplicate_non_manifold_vertices``). The
    first fan (by face order) keeps the vertex; copies are appended. Edges of
    more than two faces are left as they are.
    """
    m = len(f)
    corner_vertex = f.reshape(-1)
    # Each face edge (corner k to corner k + 1) with its undirected key.
    start = np.arange(3 * m)
    end = 3 * (start // 3) + (start % 3 + 1) % 3
    a, b = corner_vertex[start], corner_vertex[end]
    low_first = a < b
    low = np.where(low_first, start, end)  # the corner at the edge's lower vertex
    high = np.where(low_first, end, start)
    key = np.minimum(a, b) * len(v) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    key, low, high = key[order], low[order], high[order]
    # Join the corners of consecutive occurrences of one edge (at both ends).
    same = np.flatnonzero(key[1:] == key[:-1])
    rows = np.concatenate([low[same], high[same]])
    cols = np.concatenate([low[same + 1], high[same + 1]])
    graph = coo_matrix((np.ones(len(rows), np.int8), (rows, cols)), shape=(3 * m, 3 * m))
    fans, fan = connected_components(graph, directed=False)
    if fans == np.count_nonzero(np.bincount(corner_vertex, minlength=len(v))):
        return v, f  # one fan per vertex
    # Each (vertex, fan) pair once; a vertex's fans beyond its first are pinches.
    pairs, first_corner, inverse = np.unique(
        corner_vertex.astype(np.int64) * (3 * m) + fan, return_index=True, return_inverse=True
    )
    owner = corner_vertex[first_corner]
    extra = np.r_[False, owner[1:] == owner[:-1]]
    if not extra.any():
        return v, f
    new_id = owner.copy()
    new_id[extra] = len(v) + np.arange(int(extra.sum()))
    log.info(
        "MeshSurface: %d vertices where the faces meet only at a point were split, one "
        "copy for each fan of faces", len(np.unique(owner[extra])),
    )  # fmt: skip
    return np.concatenate([v, v[owner[extra]]]), new_id[inverse.reshape(-1)].reshape(-1, 3)


def area_vectors(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Half the cross product of each face's edges: (m, 3)."""
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    return 0.5 * np.cross(b - a, c - a)


def oriented_mesh(mesh: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The checked, cleaned mesh, oriented so that its signed volume is positive.

    Parameters
    ----------
    mesh : trimesh.Trimesh or (vertices, faces)

    Returns
    -------
    vertices : (n, 3) float64
    faces : (m, 3) int64
    norms : (m,) float64
        Twice each face's area (the length of its area vector).
    normals : (m, 3) float64
        Each face's unit normal (0 for faces of zero area).

    Raises
    ------
    rdmesh.MeshInputError
        Not a mesh (see :func:`as_arrays`), or every face of zero area.
    """
    v, f = clean(*as_arrays(mesh))
    area = area_vectors(v, f)
    if not np.any(np.linalg.norm(area, axis=1) > 0):
        raise MeshInputError("every face of the mesh has zero area")
    if signed_volume(v, f) < 0:
        f = f[:, ::-1].copy()
        area = -area
    norms = np.linalg.norm(area, axis=1)
    if is_closed_oriented(f):
        check_volumes(v, f, norms)
    return v, f, norms, area / np.where(norms > 0, norms, 1.0)[:, None]


def signed_volume(v: np.ndarray, f: np.ndarray) -> float:
    """The volume the faces enclose, positive when they face outward (closed meshes)."""
    return float(np.einsum("ij,ij->", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]]))) / 6


def bounding_sphere(v: np.ndarray) -> tuple[np.ndarray, float]:
    """``(centre, radius)``: the centre of the bounding box of the vertices ``(n, 3)``,
    and ``SPHERE_MARGIN`` times the largest distance of a vertex from it.

    Raises
    ------
    rdmesh.MeshInputError
        The mesh is too small, too large or too far from the origin to mesh
        (:func:`rdmesh._validate.scale_problem`).
    """
    lo, hi = v.min(axis=0), v.max(axis=0)
    centre = 0.5 * (lo + hi)
    extent = float(np.sqrt(((v - centre) ** 2).sum(axis=1).max()))
    radius = SPHERE_MARGIN * max(extent, 1e-12 * (1 + float(np.abs(centre).max())))
    problem = scale_problem(centre, radius)
    if problem:
        raise MeshInputError(problem)
    return centre, radius


def fold_edges(f: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Edges of exactly two faces whose normals differ by FOLD_ANGLE or more,
    ``(k, 2)`` vertex ids, with a warning if there are any."""
    folded = sharp_edges(f, normals, FOLD_ANGLE)
    folds = len(folded)
    if folds:
        log.warning(
            "MeshSurface: %d folds (neighbouring faces at more than %g degrees): "
            "razor-thin wedges with no feature size; bounds fine enough to resolve "
            "them end at the spacing floor (complete=False) or the vertex budget",
            folds,
            FOLD_ANGLE,
        )
    return folded


def _directed(f: np.ndarray) -> tuple[np.ndarray, int]:
    """The faces' directed edges ``(3m, 2)`` and a key base above every vertex id."""
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]).astype(np.int64)
    return directed, int(directed.max(initial=-1)) + 1


def _once(directed: np.ndarray, n: int) -> bool:
    key = np.sort(directed[:, 0] * n + directed[:, 1])
    return not np.any(key[1:] == key[:-1])


def directed_once(f: np.ndarray) -> bool:
    """No edge traversed twice in the same direction (consistently oriented)."""
    return _once(*_directed(f))


def is_closed_oriented(f: np.ndarray) -> bool:
    """Every edge in exactly two faces, traversed once in each direction."""
    directed, n = _directed(f)
    if not _once(directed, n):
        return False
    pair = np.sort(directed, axis=1)
    key = np.sort(pair[:, 0] * n + pair[:, 1])
    # Distinct directed edges: each undirected one at most twice, so exactly
    # twice when the sorted keys come in equal pairs.
    return bool(len(key) % 2 == 0 and np.all(key[0::2] == key[1::2]))


def ambiguous_share(
    core: MeshDistance, v: np.ndarray, f: np.ndarray, normals: np.ndarray, norms: np.ndarray
) -> float:
    """Share of the area next to which the winding number is not near a whole number."""
    idx = np.flatnonzero(norms > 0)
    if len(idx) > AMBIGUITY_SAMPLES:
        idx = np.sort(np.random.default_rng(0).choice(idx, AMBIGUITY_SAMPLES, replace=False))
    centroid = v[f[idx]].mean(axis=1)
    step = 1e-3 * np.sqrt(norms[idx])
    w = core.winding_number(centroid + step[:, None] * normals[idx])
    ambiguous = np.abs(w - np.round(w)) > AMBIGUOUS_MARGIN
    return float(norms[idx][ambiguous].sum() / norms[idx].sum())


def winding_ambiguity(
    core: MeshDistance, v: np.ndarray, f: np.ndarray, normals: np.ndarray, norms: np.ndarray
) -> float:
    """:func:`ambiguous_share` of a mesh whose sign comes from the winding number,
    logged (with why the side test does not apply), and checked.

    Raises
    ------
    rdmesh.MeshInputError
        The share is above ``MAX_AMBIGUOUS_SHARE``: the mesh is too open to
        tell inside from outside.
    """
    share = ambiguous_share(core, v, f, normals, norms)
    why = core.side_failure or "the mesh is not closed"
    log.info("MeshSurface: %s; the sign comes from the winding number", why)
    if share > MAX_AMBIGUOUS_SHARE:
        raise MeshInputError(
            "the mesh is too open to tell inside from outside: the winding number "
            f"is far from a whole number next to {100 * share:.0f}% of "
            f"its area (at most {100 * MAX_AMBIGUOUS_SHARE:.0f}% allowed); close its "
            "holes or orient its faces consistently"
        )
    if share > 0:
        log.warning(
            "MeshSurface: the winding number is ambiguous next to %.2g%% of the "
            "mesh's area (holes or flipped faces); holes are closed by the surface "
            "w = 0.5",
            100 * share,
        )
    return share


def orient_normals(
    v: np.ndarray, f: np.ndarray, normals: np.ndarray, norms: np.ndarray,
    sign: Callable[[np.ndarray], np.ndarray],
) -> None:  # fmt: skip
    """Flip the normals (used for the gradient on the mesh) of faces whose front is inside.

    Components oriented against the rest, or faces flipped in an open mesh,
    would otherwise give a gradient pointing inwards right on the surface.
    ``normals`` is changed in place; ``sign`` is the surface's sign test
    (negative inside).
    """
    idx = np.flatnonzero(norms > 0)
    probe = v[f[idx]].mean(axis=1) + 1e-3 * np.sqrt(norms[idx])[:, None] * normals[idx]
    normals[idx[sign(probe) < 0]] *= -1
