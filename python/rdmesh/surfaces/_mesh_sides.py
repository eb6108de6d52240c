"""A closed mesh that intersects itself: the winding number beside its faces.

The sign of such a mesh's ``f`` comes from the winding number ``w`` (the
union of what it encloses), which is costly to evaluate. But off the faces
``w`` is a whole number that changes only across a face, so on a face that
crosses no other face it is the same just in front of every point, and the
same just behind. Probed once per face, those two values give the crossings
of segments that meet only such faces (:func:`~._mesh_crossings.winding_crossings`)
and ``w`` at points whose closest point lies on such a face, straight in
front of or behind it (:func:`winding_beside`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Each face's sides are probed this far (times the bounding box's diagonal)
#: from its centroid.
SIDE_PROBE = 1e-9
#: A probe's winding number must be this close to a whole number.
PROBE_CLEAR = 0.125
#: A point is straight in front of (or behind) its closest face when the
#: cosine between its offset and the face's normal is at least this.
STRAIGHT = 1.0 - 1e-9


@dataclass
class FaceSides:
    """The winding number beside each face of a closed, oriented mesh.

    Attributes
    ----------
    w : (m, 2) float64
        ``w`` just in front of and just behind each face; NaN for faces that
        cross another face (CGAL's pairs) or whose probes are not clear of a
        half.
    code : (m,) int8
        1 where ``w`` is 0 in front and 1 behind (every hit on the face
        crosses ``f``'s zero set, inside behind), 0 for other clear faces
        (inside another part: no hit on them is a crossing), -1 where ``w``
        must be evaluated.
    normals : (m, 3) float64
        The faces' unit normals, as the faces are oriented (front: the side
        they point to).
    """

    w: np.ndarray
    code: np.ndarray
    normals: np.ndarray


def face_sides(core, v: np.ndarray, f: np.ndarray, pairs: np.ndarray) -> FaceSides:
    """Probe ``w`` (``core.winding_number``) beside every face of the closed,
    oriented mesh ``(v, f)`` whose crossing face pairs are ``pairs``."""
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    n = np.cross(b - a, c - a)
    n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    centroid = (a + b + c) / 3.0
    step = SIDE_PROBE * float(np.linalg.norm(np.ptp(v, axis=0))) * n
    w = core.winding_number(np.concatenate([centroid + step, centroid - step])).reshape(2, -1).T
    whole = np.round(w)
    clear = (np.abs(w - whole) <= PROBE_CLEAR).all(axis=1) & (whole[:, 1] - whole[:, 0] == 1)
    clear[np.asarray(pairs, np.int64).reshape(-1)] = False
    code = np.where((whole[:, 0] == 0) & (whole[:, 1] == 1), 1, 0).astype(np.int8)
    code[~clear] = -1
    whole[~clear] = np.nan
    return FaceSides(whole, code, n)


def winding_beside(
    sides: FaceSides, pts: np.ndarray, closest: np.ndarray, face: np.ndarray
) -> np.ndarray:
    """``w`` at ``(k, 3)`` points from their closest points and faces, where a
    point lies straight in front of or behind a clear face (the segment to
    its closest point meets no face, so ``w`` is that side's); NaN elsewhere."""
    off = pts - closest
    along = np.einsum("ij,ij->i", off, sides.normals[face])
    length = np.sqrt(np.einsum("ij,ij->i", off, off))
    straight = np.abs(along) >= STRAIGHT * length
    out = np.where(along > 0, sides.w[face, 0], sides.w[face, 1])
    out[~straight | (length == 0)] = np.nan
    return out


def winding_numbers(
    core,
    pts: np.ndarray,
    chunk: int,
    sides: FaceSides | None = None,
    closest: np.ndarray | None = None,
    face: np.ndarray | None = None,
) -> np.ndarray:
    """``w`` at ``(k, 3)`` points: read beside their closest faces where
    :func:`winding_beside` can (given ``sides``), evaluated (``core``, in
    chunks of ``chunk`` points) elsewhere."""
    w = np.full(len(pts), np.nan)
    if sides is not None:
        w = winding_beside(sides, pts, closest, face)
    todo = np.flatnonzero(np.isnan(w))
    for i in range(0, len(todo), chunk):
        w[todo[i : i + chunk]] = core.winding_number(pts[todo[i : i + chunk]])
    return w
