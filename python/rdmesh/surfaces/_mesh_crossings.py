"""Where line segments cross a closed triangle mesh, exactly: the crossings of
dual Voronoi segments for :class:`~rdmesh.MeshSurface` without samples of ``f``.

The faces a segment meets come from CGAL's ``AABB_tree`` with its filtered
exact ``do_intersect`` (``MeshDistance.segment_hits``). For a closed, oriented
mesh free of self-intersections ``f``'s zero set is the faces and inside and
outside alternate along a line, so the hits are every crossing. A segment
whose hits are degenerate is reported, for the sampled search.
"""

from __future__ import annotations

import numpy as np

#: Two faces met by a segment closer than this (times the bounding radius)
#: along it: the segment passes through an edge or a vertex, where one
#: crossing shows as two hits (or a touch as a crossing).
HIT_MERGE = 1e-10


def segment_crossings(surface, seg: np.ndarray):
    """The crossings of ``(k, 2, 3)`` segments with a closed mesh.

    Parameters
    ----------
    surface : MeshSurface
        Closed (``sign_method == "side"``); its ``segment_queries`` counts
        the segments.
    seg : (k, 2, 3) segments.

    Returns
    -------
    segment, s, point, rising, cos, unsure
        Per crossing of the segments not ``unsure``, in segment order then
        along it: its segment, distance from the segment's start, point,
        whether ``f`` rises through it along the segment, and ``|cos|`` of the
        angle between the face's normal and the segment; and ``(k,)`` bool:
        segments with hits through an edge or a vertex, nearly in a face's
        plane, at an end, or not alternating in and out.
    """
    seg = np.ascontiguousarray(seg, dtype=np.float64).reshape(-1, 2, 3)
    with surface._lock:
        surface.segment_queries += len(seg)
    hit, t, face = surface._core.segment_hits(seg)
    start, d = seg[:, 0], seg[:, 1] - seg[:, 0]
    length = np.sqrt(np.einsum("ij,ij->i", d, d))
    unsure = np.zeros(len(seg), bool)
    bad = ~np.isfinite(t) | (t <= 0.0) | (t >= 1.0)
    unsure[hit[bad]] = True
    hit, t, face = hit[~bad], t[~bad], face[~bad]
    dn = np.einsum("ij,ij->i", surface._normals[face], d[hit]) / length[hit]
    s = t * length[hit]
    same = hit[1:] == hit[:-1]
    merged = s[1:] - s[:-1] <= HIT_MERGE * surface.radius
    unsure[hit[1:][same & (merged | ((dn[1:] > 0) == (dn[:-1] > 0)))]] = True
    keep = ~unsure[hit]
    hit, s, t, dn = hit[keep], s[keep], t[keep], dn[keep]
    point = start[hit] + t[:, None] * d[hit]
    return hit, s, point, dn > 0, np.abs(dn), unsure
