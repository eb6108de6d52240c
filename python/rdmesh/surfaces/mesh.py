"""Triangle meshes as surfaces: the signed distance to a mesh, for remeshing.

``MeshSurface(mesh)`` is an :class:`~rdmesh.ImplicitSurface` whose ``f`` is
the signed distance to a triangle mesh, so that ``rdmesh.mesh_surface``
remeshes it with the angle bound, the sizing field and the distance bound.
"""

from __future__ import annotations

from typing import Any

from ..features.sharp_edges import sharp_curves
from ._mesh_input import bounding_sphere, fold_edges, oriented_mesh
from ._mesh_queries import MeshQueries
from ._mesh_report import MeshReport
from .oracle import ImplicitSurface


def _sharp_angle(feature_angle: Any, features: Any) -> Any:
    """The ``feature_angle`` sharp edges are found with: None (none) when
    ``features="none"`` protects nothing."""
    off = isinstance(features, str) and features == "none"
    return None if off else feature_angle


class MeshSurface(MeshQueries, MeshReport, ImplicitSurface):
    """A triangle mesh as an implicit surface: ``f`` is the signed distance to it.

    ``rdmesh.mesh_surface(MeshSurface(m), ...)`` then remeshes ``m`` with the
    angle bound, the sizing field and the distance bound.

    Parameters
    ----------
    mesh : trimesh.Trimesh or (vertices, faces)
        ``vertices`` an ``(n, 3)`` float array, ``faces`` an ``(m, 3)`` array
        of vertex indices. Equal vertices are merged and faces that repeat a
        vertex dropped.
    name : str, default "mesh"
        A label for logs and reports.
    feature_angle : float, "auto" or None, default "auto"
        Edges whose two faces' normals differ by at least this many degrees
        are sharp (CGAL's ``detect_features`` rule); they are chained into
        curves, split at corners (vertices with other than two sharp edges,
        or where the chain turns by at least this angle), and kept in the
        remesh by protecting balls (:mod:`rdmesh.features`). "auto": 60
        degrees, unless the sharp edges look like noise (many short curves,
        as on a scan) or roughness (more than twice as many edges 30 to 60
        degrees, as on a coarse organic mesh): then none, with a warning.
    features : list of (m, 3) array_like, or "none", optional
        More feature curves (see :class:`ImplicitSurface`); "none" protects
        nothing, sharp edges included.

    Attributes
    ----------
    vertices, faces : ndarray
        The cleaned input, oriented so that its signed volume is positive.
    sign_method : {"side", "winding"}
        How inside is told from outside (see Notes).
    cap : float
        ``f`` is clamped to ``[-cap, cap]`` (``0.1 R``).
    ambiguous_share : float
        Share of the area next to which the winding number is far from a
        whole number (0 for closed meshes).
    folds, fold_edges : int, (k, 2) int64
        How many edges have two faces whose normals differ by more than 150
        degrees (razor-thin wedges; see Notes; logged as a warning), and which.
    sharp_edges : (E, 2) int64
        The sharp edges kept (vertex index pairs; short dangling chains are
        left out as noise).
    sharp_curves : list of (k, 3) float64
        Those edges chained into polylines.
    self_intersections : (k, 2) int64
        Pairs of faces that cross, for a closed manifold input that
        intersects itself (CGAL's ``self_intersections``); empty otherwise.
        A run on such an input returns its mesh with ``complete=False`` and
        ``report["input"]`` naming where (:meth:`input_report`).
    lipschitz : float or None
        1 when ``f`` is the clamped signed distance (closed input): the seeding
        grid skips samples it proves needless. None with the winding-number sign.
    exact_crossings, segment_queries : callable, int
        Dual segments' crossings from the faces they meet (see Notes); the count.
    unit_gradient : bool
        The gradient is a unit vector wherever ``f`` is differentiable
        (closed input): the report's singular-point search is skipped.

    Raises
    ------
    rdmesh.MeshInputError
        (a ValueError) The input is not a mesh: not a Trimesh or a pair,
        wrong shapes, empty, non-finite vertices, face indices out of range
        or not integers, all faces of zero area; or it is too open to tell
        inside from outside.

    Notes
    -----
    **Distance.** Unsigned distances and closest points come from CGAL's
    ``AABB_tree`` (C++, GIL released, vectorised). The gradient is
    ``sign * (p - closest) / |p - closest|``; within ``1e-9 R`` of the mesh,
    the closest face's outward normal. ``f`` is the signed distance clamped
    to ``+-cap`` (``0.1 R``): points that a k-d tree of the vertices shows to
    be farther skip the exact query, slowest there (near the medial axis).
    The zero set, the sign and ``f`` within ``cap`` are unchanged;
    :meth:`signed_distance` is not clamped. Queries may run in several threads.
    Dual segments meet the faces where CGAL's exact ``do_intersect`` says (no
    samples of ``f``, no root searches); degenerate hits, and open meshes'
    segments near a hole, fall back to sampling ``f``.

    **Sign.** Accepted inputs:

    - *Closed* meshes (every edge in two faces, consistently oriented,
      combinatorially manifold, no face of zero area, not self-intersecting):
      the sign of ``(p - c) . n`` at the closest point ``c``, with ``n`` the
      angle-weighted pseudo-normal of the face, edge or vertex ``c`` lies on
      (exact for such meshes: Baerentzen and Aanaes 2005); CGAL's
      ``Side_of_triangle_mesh`` (ray casting with exact predicates) where
      that product is too close to 0, for far points, and for every point if
      a face's normal points into the solid. Inward-oriented meshes
      (negative volume) are flipped first.
    - *Everything else*: the generalized winding number ``w`` (Jacobson et
      al. 2013; far clusters by their dipole, Barill et al. 2018, within a
      few percent), ``f = clip(4 (1 - 2w), -1, 1) * distance``. Away from
      holes ``w`` is a whole number and ``f`` is the signed distance; across
      a hole ``w`` passes 0.5 smoothly, so the zero set closes the hole with
      the surface ``w = 0.5`` and ``f`` stays continuous (a half sphere
      becomes a closed half ball this way). Self-intersecting meshes
      (overlapping closed parts) give their union (``w >= 1`` inside).
      Inconsistently oriented faces are not repaired: ``w`` is then wrong
      near them.
    - *Badly open* meshes (a flat patch, a single triangle): if faces next
      to which ``w`` is farther than 0.25 from a whole number hold more than
      20 % of the area, :class:`~rdmesh.MeshInputError` is raised; a smaller
      nonzero share is logged as a warning.

    **What the remesh guarantees.** The zero set of ``f`` is the input mesh
    (plus hole patches), but it is piecewise flat and ``f`` has a kink on the
    medial axis, which reaches the surface at every concave edge, so the
    theorems for smooth surfaces do not apply. What holds by construction,
    for a run that ends with ``complete=True``: every angle is at least the
    angle bound, every surface Delaunay ball is below the size bound, every
    facet's circumcentre is within the distance bound of its surface centre,
    every vertex lies on the input (to rounding, or the root tolerance where
    sampled), and every output triangle lies in a surface Delaunay ball
    centred on the input, so it is within the size bound of the input.
    **Both ways** (closed): the input's vertices and creased edges and the output's edge
    midpoints are measured against the other surface, and input points beyond the distance
    bound inserted (``stats["distance_check"]``; :mod:`rdmesh.refine.deviation`). Keeping
    the input's topology is sampled, not proven: it holds when the size bound is below the
    feature size of the shape the mesh approximates (scans, organic shapes). Sharp creases
    (CAD models) are kept through ``feature_angle``: each sharp-edge chain is
    covered by protecting balls centred on the input's own edges (the output
    has a vertex at every corner and edges along every chain;
    ``SurfaceMesh.features`` reports the check). Razor-thin wedges (two
    faces folded onto each other, as noise flips a sliver) have no feature
    size: refinement points there fall below the spacing floor and are
    refused, and the mesh comes back with ``complete=False`` (or at the
    vertex budget), perhaps not closed.
    """

    def __init__(
        self, mesh: Any, *, name: str = "mesh", feature_angle: Any = "auto", features: Any = None
    ) -> None:
        self.vertices, self.faces, norms, self._normals = oriented_mesh(mesh)
        centre, radius = bounding_sphere(self.vertices)
        self._start_queries(radius)
        self.fold_edges = fold_edges(self.faces, self._normals)
        self.folds = len(self.fold_edges)
        self._set_sign(norms)
        self._find_self_intersections()
        self.feature_angle, self.sharp_edges, self.sharp_curves = sharp_curves(
            self.vertices, self.faces, _sharp_angle(feature_angle, features)
        )
        super().__init__(
            self._signed_distance, (centre, radius), gradient=self._gradient, name=name,
            features=features,
        )  # fmt: skip
