"""The oracle half of :class:`~rdmesh.MeshSurface`: distance, sign, gradient and
winding number of a triangle mesh.

:class:`MeshQueries` holds the C++ ``MeshDistance`` (CGAL's ``AABB_tree``, the
pseudo-normal and ray-casting side tests and the winding number, the GIL
released) and a k-d tree of the vertices that skips the exact query far from
the mesh. What ``f``, its sign and its gradient are: the notes of
:class:`~rdmesh.MeshSurface`.
"""

from __future__ import annotations

from functools import partial

import numpy as np
from scipy.spatial import cKDTree

from .._errors import MeshInputError
from ..core import MeshDistance, PointMap
from ._mesh_crossings import CrossingFaces, hole_balls, segment_crossings, winding_crossings
from ._mesh_input import is_closed_oriented, orient_normals, winding_ambiguity
from ._mesh_sides import face_sides, winding_numbers

#: Below this distance (times the bounding radius) the gradient is the normal
#: of the closest face: there ``p - closest`` is too short to give a direction.
NORMAL_DISTANCE = 1e-9
#: Open meshes: f = clip(WINDING_SLOPE * (1 - 2 w), -1, 1) * distance, so the
#: sign follows the winding number w thresholded at 0.5, and f stays
#: continuous across the band |w - 0.5| < 1 / (2 WINDING_SLOPE) that spans
#: each hole.
WINDING_SLOPE = 4.0
#: f is the signed distance clamped to +-DISTANCE_CAP x the bounding radius:
#: points certainly farther (by a k-d tree of the vertices) skip the exact
#: query, which is slowest there (near the medial axis many faces are almost
#: equally far). The zero set and f within the cap are unchanged.
DISTANCE_CAP = 0.1
#: Points evaluated per call of the C++ core (bounds the temporary arrays).
_CHUNK = 1 << 18


def _points(points: np.ndarray) -> np.ndarray:
    """Query points as a C-contiguous (N, 3) float64 array, checked finite."""
    pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    bad = ~np.isfinite(pts).all(axis=1)
    if bad.any():
        raise ValueError(f"query point {int(np.argmax(bad))} is not finite")
    return pts


class MeshQueries(CrossingFaces):
    """The signed distance to a mesh, its gradient, closest points and winding number.

    A base of :class:`~rdmesh.MeshSurface`, which sets ``vertices``, ``faces``
    and ``_normals`` (the oriented mesh and its unit face normals), then calls
    :meth:`_start_queries` (the C++ core ``_core``, ``cap``, the k-d tree) and
    :meth:`_set_sign` (``sign_method`` and the attributes that follow from it);
    ``radius`` comes from :class:`~rdmesh.ImplicitSurface`. ``_signed_distance``
    (clamped) and ``_gradient`` are the surface's ``f`` and gradient.
    """

    def _start_queries(self, radius: float) -> None:
        """Build the C++ ``MeshDistance`` and the k-d tree; ``cap`` from ``radius``.

        Raises
        ------
        rdmesh.MeshInputError
            The C++ core refuses the mesh.
        """
        v, f = self.vertices, self.faces
        try:
            self._core = MeshDistance(v, f, side=is_closed_oriented(f))
        except ValueError as exc:
            raise MeshInputError(str(exc)) from None
        self.cap = DISTANCE_CAP * radius
        edges = np.linalg.norm(v[f] - v[np.roll(f, 1, axis=1)], axis=2)
        # Every point of the mesh is within this of a vertex (a face's
        # circumradius or half its longest edge, both <= longest edge / sqrt 3).
        self._vertex_gap = float(edges.max()) / np.sqrt(3.0)
        self._kdtree = cKDTree(v)
        #: The face each exact crossing of this run lies on, by its coordinates.
        self._on_face = PointMap()

    def _set_sign(self, norms: np.ndarray) -> None:
        """Choose how inside is told from outside (``sign_method``, ``ambiguous_share``,
        ``lipschitz``, ``unit_gradient``), then turn the face normals to the outside.

        Raises
        ------
        rdmesh.MeshInputError
            The mesh is too open to tell inside from outside.
        """
        #: f is this-Lipschitz (the clamped signed distance), or None (winding sign).
        self.lipschitz: float | None = None
        #: The gradient is a unit vector wherever f is differentiable.
        self.unit_gradient = False
        v, f = self.vertices, self.faces
        #: Exact crossings (closed meshes; None: sampled), their count; f > 0 outside the sphere.
        self.exact_crossings, self.segment_queries, self.sphere_clear = None, 0, False
        #: A closed mesh that intersects itself: w beside each face (FaceSides), else None.
        self._face_sides = None
        if self._core.has_side:
            self.sign_method = "side"
            self.ambiguous_share = 0.0
            self.lipschitz, self.unit_gradient, self.sphere_clear = 1.0, True, True
            self.exact_crossings = partial(segment_crossings, self)
        else:
            self.sign_method = "winding"
            self.ambiguous_share = winding_ambiguity(self._core, v, f, self._normals, norms)
            self._holes = hole_balls(v, f)
            self.exact_crossings = partial(winding_crossings, self)
            pairs = self._core.self_intersections()
            if len(pairs):  # closed and oriented: the faces clear of the crossings
                self._face_sides = face_sides(self._core, v, f, pairs)
        orient_normals(v, f, self._normals, norms, self._sign)

    def _query(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Distance, closest point, closest face and sign factor s in [-1, 1]."""
        dist, closest, face, side = _nearest(self._core, pts)
        if self.sign_method == "side":
            return dist, closest, face, side.astype(np.float64)
        return dist, closest, face, self._winding_factor(pts, closest, face)

    def _winding_factor(self, pts: np.ndarray, closest=None, face=None) -> np.ndarray:
        """clip(WINDING_SLOPE (1 - 2 w), -1, 1); see :func:`winding_numbers`."""
        sides = self._face_sides if face is not None else None
        w = winding_numbers(self._core, pts, _CHUNK, sides, closest, face)
        return np.clip(WINDING_SLOPE * (1.0 - 2.0 * w), -1.0, 1.0)

    def _signed_distance(self, points: np.ndarray) -> np.ndarray:
        pts = _points(points)
        if len(pts) == 0:
            return np.zeros(0)
        # Farther than cap + gap from every vertex means farther than cap from the mesh.
        dv, _ = self._kdtree.query(
            pts, distance_upper_bound=self.cap + self._vertex_gap, workers=-1
        )
        near = np.flatnonzero(np.isfinite(dv))
        far = np.flatnonzero(~np.isfinite(dv))
        out = np.empty(len(pts))
        if len(near):
            dist, _, _, s = self._query(pts[near])
            out[near] = s * np.minimum(dist, self.cap)
        if len(far):
            out[far] = self.cap * self._sign(pts[far])
        return out

    def _sign(self, pts: np.ndarray) -> np.ndarray:
        if self.sign_method == "side":
            return np.concatenate(
                [self._core.side(pts[i : i + _CHUNK]) for i in range(0, len(pts), _CHUNK)]
            ).astype(np.float64)
        return self._winding_factor(pts)

    def _gradient(self, points: np.ndarray) -> np.ndarray:
        pts = _points(points)
        # A crossing's gradient is its face's normal: facet centres and
        # samples are crossings, so most points need no query.
        face = self._on_face.get(pts)
        known = face >= 0
        g = np.empty_like(pts)
        g[known] = self._normals[face[known]]
        g[~known] = queried_gradient(self, pts[~known])
        return g

    def signed_distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distance to the mesh at ``(N, 3)`` points: ``(N,)``, negative inside.

        Not clamped (``f``, the oracle, is clamped to ``+-cap``). For meshes
        whose sign comes from the winding number, the distance times
        ``clip(4 (1 - 2w), -1, 1)`` (see the class notes).
        """
        pts = _points(points)
        if len(pts) == 0:
            return np.zeros(0)
        dist, _, _, s = self._query(pts)
        return s * dist

    def closest_points(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Closest points on the mesh ``(N, 3)`` and the faces they lie on ``(N,)``."""
        pts = _points(points)
        if len(pts) == 0:
            return np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
        # No sign: a winding number per point would cost more than the query.
        _, closest, face, _ = _nearest(self._core, pts)
        return closest, face

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Distance to the mesh at ``(N, 3)`` points: ``(N,)``, unsigned."""
        pts = _points(points)
        return _nearest(self._core, pts)[0] if len(pts) else np.zeros(0)

    def winding_number(self, points: np.ndarray) -> np.ndarray:
        """Generalized winding number of the mesh at ``(N, 3)`` points: ``(N,)``."""
        pts = _points(points)
        return self._core.winding_number(pts)


def _nearest(core_, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Distance, closest point, closest face and the core's side of it, in chunks."""
    parts = [core_.query(pts[i : i + _CHUNK]) for i in range(0, len(pts), _CHUNK)]
    if len(parts) == 1:
        return parts[0]
    return tuple(np.concatenate(x) for x in zip(*parts, strict=True))


def queried_gradient(q: MeshQueries, pts: np.ndarray) -> np.ndarray:
    """The gradient of ``q``'s ``f`` at ``(N, 3)`` points from closest-point queries."""
    if len(pts) == 0:
        return np.zeros((0, 3))
    dist, closest, face, s = q._query(pts)
    near = dist <= NORMAL_DISTANCE * q.radius
    g = np.empty_like(pts)
    far = ~near
    # Outside s = 1 and p - closest points out; inside s = -1 and it points in.
    g[far] = np.sign(s[far])[:, None] * (pts[far] - closest[far]) / dist[far, None]
    g[near] = q._normals[face[near]]
    band = far & (np.abs(s) < 1.0)
    if band.any():
        # Open meshes, across a hole: f = s(w) d, so grad f = s grad d + d grad s,
        # with grad s from central differences of w (smooth there: no face within d).
        p, d = pts[band], dist[band]
        h = np.clip(0.1 * d, NORMAL_DISTANCE * q.radius, 1e-4 * q.radius)
        step = h[None, :, None] * np.eye(3)[:, None, :]
        probes = np.concatenate([p[None] + step, p[None] - step])
        sw = q._winding_factor(probes.reshape(-1, 3)).reshape(2, 3, -1)
        grad_s = ((sw[0] - sw[1]) / (2 * h)).T
        unit = (p - closest[band]) / d[:, None]
        g[band] = s[band, None] * unit + d[:, None] * grad_s
    return g
