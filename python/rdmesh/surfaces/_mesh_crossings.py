"""Where line segments cross a closed triangle mesh, exactly: the crossings of
dual Voronoi segments for :class:`~rdmesh.MeshSurface` without samples of ``f``.

The faces a segment meets come from CGAL's ``AABB_tree`` with its filtered
exact ``do_intersect`` (``MeshDistance.segment_hits``). For a closed, oriented
mesh free of self-intersections ``f``'s zero set is the faces and inside and
outside alternate along a line, so the hits are every crossing. A segment
whose hits are degenerate is reported, for the sampled search.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._mesh_holes import rim_half_edges

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
    h = _Hits.of(surface, seg)
    hit = h.hit
    dn = np.einsum("ij,ij->i", surface._normals[h.face], h.d[hit]) / h.length[hit]
    same = hit[1:] == hit[:-1]
    h.unsure[hit[1:][same & ((dn[1:] > 0) == (dn[:-1] > 0))]] = True
    keep = ~h.unsure[hit]
    return h.crossings(keep, dn[keep] > 0, np.abs(dn[keep]))


@dataclass
class _Hits:
    """A segment's hits (``MeshDistance.segment_hits``) but the degenerate ones:
    ``unsure`` marks the segments with a hit nearly in a face's plane or at an
    end, or two within ``HIT_MERGE`` (through an edge or a vertex)."""

    start: np.ndarray  # (k, 3)
    d: np.ndarray  # (k, 3) end - start
    length: np.ndarray  # (k,)
    hit: np.ndarray  # (m,) segment of each hit, sorted
    t: np.ndarray  # (m,) the hit at start + t d
    face: np.ndarray  # (m,)
    unsure: np.ndarray  # (k,) bool
    on_face: object  # the surface's table of its crossings' faces (core.PointMap)

    @classmethod
    def of(cls, surface, seg: np.ndarray) -> _Hits:
        hit, t, face = surface._core.segment_hits(seg)
        start, d = seg[:, 0], seg[:, 1] - seg[:, 0]
        length = np.sqrt(np.einsum("ij,ij->i", d, d))
        unsure = np.zeros(len(seg), bool)
        bad = ~np.isfinite(t) | (t <= 0.0) | (t >= 1.0)
        unsure[hit[bad]] = True
        hit, t, face = hit[~bad], t[~bad], face[~bad]
        s = t * length[hit]
        same = hit[1:] == hit[:-1]
        unsure[hit[1:][same & (s[1:] - s[:-1] <= HIT_MERGE * surface.radius)]] = True
        return cls(start, d, length, hit, t, face, unsure, surface._on_face)

    def crossings(self, keep: np.ndarray, rising: np.ndarray, cos: np.ndarray):
        """The hits ``keep`` as crossings: :func:`segment_crossings`' tuple;
        the surface's table keeps the face of each (``crossing_faces``)."""
        hit, t = self.hit[keep], self.t[keep]
        point = self.start[hit] + t[:, None] * self.d[hit]
        self.on_face.add(point, self.face[keep])
        return hit, t * self.length[hit], point, rising, cos, self.unsure


class CrossingFaces:
    """The faces of the crossings a :class:`~rdmesh.MeshSurface` reported
    (``_Hits.crossings`` records them in its ``_on_face``, a
    ``core.PointMap``): facet centres and samples are crossings, so their
    gradients need no closest-point query."""

    def forget_crossings(self) -> None:
        """Forget the faces of the crossings found so far.

        :func:`rdmesh.mesh_surface` calls it when a run starts, so that no run
        depends on an earlier one, and when it ends, to free the table.
        """
        self._on_face.clear()

    def crossing_faces(self, points: np.ndarray) -> np.ndarray:
        """The faces that this run's exact crossings lie on.

        Parameters
        ----------
        points : (N, 3) array

        Returns
        -------
        (N,) int64 array
            The face each point lies on where it is, bit for bit, an exact
            crossing this surface reported during the current run (of a dual
            Voronoi edge, a seeding edge or a ray); -1 for any other point.
        """
        return self._on_face.get(np.ascontiguousarray(points, np.float64).reshape(-1, 3))


#: Open meshes: an end whose winding number is farther than this from a whole
#: number is near a hole (where ``f``'s zero set leaves the faces).
WINDING_CLEAR = 0.125
#: ... and a segment that comes within this many times a hole's radius of the
#: hole's centre may cross the surface that closes it (``w = 0.5``).
HOLE_MARGIN = 1.5


def hole_balls(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The holes of an open mesh as balls: per loop of boundary edges, the
    centroid of its vertices and ``HOLE_MARGIN`` times their largest distance
    from it. ``((L, 3), (L,))``."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    rim = rim_half_edges(f)[:, :2]
    if len(rim) == 0:
        return np.zeros((0, 3)), np.zeros(0)
    ids, local = np.unique(rim, return_inverse=True)
    local = local.reshape(-1, 2)
    n = len(ids)
    graph = coo_matrix((np.ones(len(local)), (local[:, 0], local[:, 1])), shape=(n, n))
    k, label = connected_components(graph, directed=False)
    pts = v[ids]
    centres = np.stack([np.bincount(label, pts[:, a], k) for a in range(3)], axis=1)
    centres /= np.bincount(label, minlength=k)[:, None]
    reach = np.linalg.norm(pts - centres[label], axis=1)
    radii = np.zeros(k)
    np.maximum.at(radii, label, reach)
    return centres, HOLE_MARGIN * radii


def _near_balls(seg: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """(k,) bool: segments that meet one of the balls."""
    near = np.zeros(len(seg), bool)
    a, d = seg[:, 0], seg[:, 1] - seg[:, 0]
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    for c, r in zip(centres, radii, strict=True):
        t = np.clip(np.einsum("ij,ij->i", c - a, d) / dd, 0.0, 1.0)
        q = a + t[:, None] * d - c
        near |= np.einsum("ij,ij->i", q, q) <= r * r
    return near


def winding_crossings(surface, seg: np.ndarray):
    """:func:`segment_crossings` for an open mesh, whose sign is the winding number's.

    Across a face the winding number ``w`` jumps by one (up when going to the
    face's back); away from holes it is a whole number off the faces, so the
    crossings are the hits where it passes 0.5, and a segment that meets no
    face has none. Segments near a hole (in a hole's ball, or with an end
    whose ``w`` is not clear of 0.5's band) and segments whose jumps do not
    add up to ``w``'s change between the ends (faces oriented against their
    neighbours) are ``unsure``. ``w`` is evaluated at the ends of the segments
    that meet a face only, and counted in ``surface.evaluations``. A closed
    mesh that intersects itself has ``surface._face_sides``
    (:class:`~rdmesh.surfaces._mesh_sides.FaceSides`): segments that meet
    only faces crossing no other face take their crossings from those faces,
    with no ``w`` at their ends.
    """
    seg = np.ascontiguousarray(seg, dtype=np.float64).reshape(-1, 2, 3)
    k = len(seg)
    h = _Hits.of(surface, seg)
    hit, unsure = h.hit, h.unsure  # unsure is h's own: crossings() returns it
    unsure |= _near_balls(seg, *surface._holes)
    sides = surface._face_sides
    side_of_hit = None if sides is None else sides.code[h.face]
    known = np.zeros(k, bool)
    if side_of_hit is not None:
        known = np.bincount(hit, side_of_hit < 0, minlength=k) == 0
    # w at the ends of the other segments that meet a face.
    met = np.zeros(k, bool)
    met[hit] = True
    met &= ~unsure & ~known
    ends, back = np.unique(seg[met].reshape(-1, 3), axis=0, return_inverse=True)
    with surface._lock:
        surface.segment_queries += k
        surface.evaluations += len(ends)
    whole = np.zeros((k, 2))
    if len(ends):
        w = surface._core.winding_number(ends)[back.reshape(-1)].reshape(-1, 2)
        whole[met] = np.round(w)
        unsure[np.flatnonzero(met)[(np.abs(w - whole[met]) > WINDING_CLEAR).any(axis=1)]] = True
    v, f = surface.vertices, surface.faces[h.face]
    raw = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    raw /= np.maximum(np.linalg.norm(raw, axis=1), 1e-300)[:, None]
    dn = np.einsum("ij,ij->i", raw, h.d[hit]) / h.length[hit]
    jump = np.where(dn < 0, 1.0, -1.0)  # to the face's back: w goes up by one
    unsure |= met & (whole[:, 0] + np.bincount(hit, jump, minlength=k) != whole[:, 1])
    sel = np.flatnonzero(~unsure[hit] & ~known[hit])
    # w just after each hit: the start's plus the jumps so far along its segment.
    after = whole[hit[sel], 0] + _cumsum_by(hit[sel], jump[sel])
    inside = np.zeros(len(hit), bool)
    inside[sel] = after - jump[sel] > 0.5
    keep = np.zeros(len(hit), bool)
    keep[sel] = inside[sel] != (after > 0.5)
    if side_of_hit is not None:
        # On a face with w = 0 in front and 1 behind: inside before the hit
        # when the segment goes to the face's front.
        by_face = np.flatnonzero(known[hit] & ~unsure[hit] & (side_of_hit == 1))
        keep[by_face] = True
        inside[by_face] = dn[by_face] > 0
    return h.crossings(keep, inside[keep], np.abs(dn[keep]))


def _cumsum_by(group: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Running sums of ``x`` within runs of equal, sorted ``group``."""
    c = np.cumsum(x)
    first = np.r_[True, group[1:] != group[:-1]]
    # The index of each run's first element, carried forward.
    head = np.maximum.accumulate(np.where(first, np.arange(len(x)), 0))
    return c - (c - x)[head]
