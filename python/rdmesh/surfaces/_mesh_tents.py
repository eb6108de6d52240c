"""Tents: what closes a hole whose flat cap cannot (an open sheet's, or one
that would cross the mesh), and how coarsely a remesh may follow them.

A tent (:func:`tent`) is a dome over the rim, leaving it square to the faces
on it. :mod:`._mesh_holes`
tries it at :data:`TENT_HEIGHTS` in turn; the part of the remesh on it is cut
off afterwards, so :func:`tent_slack` lets the size and distance bounds
grow with the distance from the input there.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .._vectors import row_norms

#: Heights of the tents tried over a hole whose cap fails, in turn, in radii of
#: its rim (negative: behind the faces next to it).
TENT_HEIGHTS = (-0.5, 0.5, -1.0, 1.0, -0.25, 0.25)
#: A tent's rings of vertices from its rim to its top (:func:`tent`).
TENT_RINGS = 8


def rim_frame(
    vertices: np.ndarray, loop: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float, float]:
    """A rim's centre (the mean of its edges' midpoints, by length), the unit
    normal of its vector area (along the faces' normals next to it), that area
    and the rim's radius (root mean square distance of its vertices to the centre)."""
    p = vertices[loop]
    q = np.roll(p, -1, axis=0)
    length = row_norms(q - p)
    centre = ((p + q) * (0.5 * length)[:, None]).sum(axis=0) / max(float(length.sum()), 1e-300)
    vec = 0.5 * np.cross(p - centre, q - centre).sum(axis=0)
    area = float(np.linalg.norm(vec))
    radius = float(np.sqrt(np.mean(np.sum((p - centre) ** 2, axis=1))))
    return centre, vec / max(area, 1e-300), area, radius


def _rim_faces(vertices: np.ndarray, loop: np.ndarray, third: np.ndarray):
    """The unit normals ``(k, 3)`` of the faces on a rim's edges (``third``: their
    third vertices), and its :func:`rim_frame` with the normal turned to their
    side (an inner hole's rim runs against its faces' normals)."""
    p, q = vertices[loop], vertices[np.roll(loop, -1)]
    n = np.cross(q - p, vertices[third] - p)
    n /= np.maximum(row_norms(n), 1e-300)[:, None]
    centre, normal, area, radius = rim_frame(vertices, loop)
    return n, centre, normal * np.copysign(1.0, np.median(n @ normal)), area, radius


def tent(vertices: np.ndarray, loop: np.ndarray, third: np.ndarray, first: int, height: float):
    """A tent over one rim: a dome ``|height|`` rim radii tall (negative heights
    behind the faces on the rim; ``third``: their third vertices), leaving the rim
    square to those faces and closing over the rim's centre, in
    :data:`TENT_RINGS` rings that follow ever smoother loops (the rim's lowest
    harmonics) so that a scan's jagged rim does not fold it. Returns the new
    vertices ``(r k + 1, 3)``, numbered from ``first`` (ring by ring, the top
    last), and the triangles, oriented against the rim's half-edges as
    :func:`~._mesh_holes.cap`'s. An open sheet's flat cap lies on the sheet; a
    tent stands off it, with no crease or cone point that refinement would chase."""
    p = vertices[loop]
    n, centre, normal, _, radius = _rim_faces(vertices, loop, third)
    side = np.copysign(1.0, height)
    at = side * _smooth(n + np.roll(n, 1, axis=0))  # by rim vertex
    tall, smooth = abs(height) * radius, _smooth(p)
    rings = []
    for t in np.arange(1, TENT_RINGS) / TENT_RINGS:
        a = np.sin(0.5 * np.pi * t)
        way = (1 - a) * at + a * side * normal
        way /= np.maximum(row_norms(way), 1e-300)[:, None]
        rim = p + t * (smooth - p)  # jagged to smooth ...
        rings.append(rim + a * tall * way + (1 - np.cos(0.5 * np.pi * t)) * (centre - rim))
    top = centre + tall * side * normal
    k, m = len(loop), len(rings)
    ids = np.concatenate([loop[None], first + np.arange(m * k).reshape(m, k)])
    i, j = np.arange(k), np.roll(np.arange(k), -1)
    lo, hi = ids[:-1], ids[1:]
    tri = np.concatenate([
        np.stack([lo[:, j], lo[:, i], hi[:, i]], axis=-1).reshape(-1, 3),
        np.stack([lo[:, j], hi[:, i], hi[:, j]], axis=-1).reshape(-1, 3),
        np.c_[ids[-1, j], ids[-1, i], np.full(k, first + m * k)],
    ])  # fmt: skip
    return np.concatenate([*rings, top[None]]), tri.astype(np.int64)


#: A tent closes a rim whose faces on it turn less than this from the rim's
#: normal (degrees; the median over its edges): the rim of a sheet.
TENT_TURN = 60.0


def faces_along_normal(vertices: np.ndarray, loop: np.ndarray, third: np.ndarray) -> bool:
    """Whether the faces on a rim face along its normal, either way
    (:data:`TENT_TURN`): a tent, leaving the rim square to them, then stands off
    the sheet; on a rim whose faces are a skirt square to the sheet it would lie
    along the sheet."""
    n, _, normal, area, _ = _rim_faces(vertices, loop, third)
    return area > 0 and float(np.median(n @ normal)) >= np.cos(np.radians(TENT_TURN))


#: A tent's top follows its rim's lowest harmonics only (:func:`_smooth`).
TENT_HARMONICS = 6


def _smooth(x: np.ndarray) -> np.ndarray:
    """Values ``(k, 3)`` around a closed loop with their harmonics above
    :data:`TENT_HARMONICS` removed."""
    c = np.fft.rfft(x, axis=0)
    c[TENT_HARMONICS + 1 :] = 0
    return np.fft.irfft(c, n=len(x), axis=0)


#: On a tent, the size bound grows to this fraction of a facet's distance from
#: the input, and the distance bound to :data:`TENT_DISTANCE_GRADE` of it: the
#: part of the remesh there is cut off, and only needs to stay a surface.
TENT_GRADE, TENT_DISTANCE_GRADE = 0.5, 0.05


def input_clearance(vertices: np.ndarray, faces: np.ndarray) -> tuple[cKDTree, float]:
    """A k-d tree of the input's ``vertices`` and the farthest a point of one of
    its ``faces`` lies from a vertex of it (its longest edge over sqrt 3): with
    them, :func:`tent_slack` bounds a point's distance to the faces from below."""
    edges = row_norms(
        vertices[faces].reshape(-1, 3) - vertices[np.roll(faces, 1, axis=1)].reshape(-1, 3)
    )
    return cKDTree(vertices), float(edges.max()) / np.sqrt(3)


def tent_slack(surface, centres: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The size and distance bounds ``(k,)`` each that the facets with surface
    centres ``(k, 3)`` on a tent of ``surface`` (a :class:`~rdmesh.MeshSurface`)
    get at least (:data:`TENT_GRADE` and :data:`TENT_DISTANCE_GRADE` times a
    lower bound of the distance to the input's faces; 0 off the tents), for
    :meth:`~rdmesh.refine.criteria.FacetCriteria.bad`; None without tents.

    A centre is on a tent where it is an exact crossing of a face with a tent
    vertex; the bound is its distance to the nearest input vertex, less the
    farthest any point of an input face lies from a vertex of it."""
    holes = getattr(surface, "holes", None)
    if holes is None or holes.clearance is None:
        return None
    d = np.zeros(len(centres))
    face = surface.crossing_faces(centres)
    mine = face >= 0
    mine[mine] = (surface.faces[face[mine]] >= holes.base).any(axis=1)
    if mine.any():
        tree, gap = holes.clearance
        d[mine] = np.maximum(tree.query(centres[mine])[0] - gap, 0.0)
    return TENT_GRADE * d, TENT_DISTANCE_GRADE * d
