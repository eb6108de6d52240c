"""Triangle meshes as surfaces: the signed distance to a mesh, for remeshing.

``MeshSurface(mesh)`` is an :class:`~rdmesh.ImplicitSurface` whose ``f`` is
the signed distance to a triangle mesh, so that ``rdmesh.mesh_surface``
remeshes it with the angle bound, the sizing field and the distance bound.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validate import choice
from ..features.sharp_edges import sharp_curves
from ._mesh_holes import (
    HOLES,
    close_holes,
    drop_pinch_fans,
    find_holes,
    rim_half_edges,
    trim_rims,
)
from ._mesh_input import area_vectors, bounding_sphere, fold_edges, oriented_mesh
from ._mesh_queries import MeshQueries
from ._mesh_report import MeshReport
from .oracle import ImplicitSurface


def _sharp_angle(feature_angle: Any, features: Any) -> Any:
    """The ``feature_angle`` sharp edges are found with: None (none) when
    ``features="none"`` protects nothing."""
    off = isinstance(features, str) and features == "none"
    return None if off else feature_angle


def _holes(surface, norms, holes: str, features: Any):
    """The holes :class:`MeshSurface` keeps (None with ``holes="fill"`` or none),
    after their rims' slivers are trimmed (``surface.vertices``, ``faces`` and
    ``_normals`` updated); returns them and the faces' area norms."""
    if holes != "keep" or len(rim_half_edges(surface.faces)) == 0:  # closed: one pass
        return None, norms
    if _sharp_angle(0, features) is None:
        raise ValueError(
            "holes='keep' protects the rims of an open mesh's holes, which features='none' "
            "forbids: use holes='fill' with it"
        )
    v, f, fans = drop_pinch_fans(surface.vertices, surface.faces)
    v, f, dropped, added = trim_rims(v, f)
    dropped += fans
    if dropped or added:
        area = area_vectors(v, f)
        norms = np.linalg.norm(area, axis=1)
        surface.vertices, surface.faces = v, f
        surface._normals = area / np.where(norms > 0, norms, 1.0)[:, None]
    found = find_holes(v, f)  # None if trimming closed the mesh
    if found is not None:
        found.trimmed = (dropped, added)
    return found, norms


class MeshSurface(MeshQueries, MeshReport, ImplicitSurface):
    """A triangle mesh as an implicit surface: ``f`` is the signed distance to it.

    ``rdmesh.mesh_surface(MeshSurface(m), ...)`` then remeshes ``m`` with the
    angle bound, the sizing field and the distance bound.

    Parameters
    ----------
    mesh : trimesh.Trimesh or (vertices, faces)
        ``vertices`` an ``(n, 3)`` float array, ``faces`` an ``(m, 3)`` array
        of vertex indices. Equal vertices are merged, degenerate and repeated
        faces dropped, faces turned to agree with their neighbours.
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
        nothing, sharp edges included (and needs ``holes="fill"`` on an open
        mesh).
    holes : {"keep", "fill"}, default "keep"
        An open mesh's holes. "keep": the remesh has the input's boundary;
        each hole's rim is a protected feature curve (split at turns of 60
        degrees or more), the hole is closed while meshing by a cap (CGAL's
        ``triangulate_hole_polyline``; where it crosses the mesh or lies on
        it, as a sheet's, a dome; else the winding number's patch), and that
        part of the remesh is cut off along the rims (``report["holes"]``). Rim
        slivers (edges under 10 degrees apart) are trimmed first; if the rims
        cannot be protected, :func:`rdmesh.mesh_surface` meshes the input again
        with the holes filled. Needs ``method="boissonnat-oudot"``. "fill":
        the remesh is closed, the holes patched by the surface where the
        winding number is 0.5.

    Attributes
    ----------
    vertices, faces : ndarray
        The cleaned input, oriented so that its signed volume is positive;
        with holes kept, ``faces`` ends with the caps over them.
    input_face_count : int
        The input's faces: ``faces[:input_face_count]``.
    holes : Holes or None
        The rims, their curves and the caps (``holes="keep"`` on an open
        mesh), else None.
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
        or not integers, complex coordinates, all faces of zero area, a flat
        closed component; or it is too open to tell inside from outside.

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

    **Sign.** *Closed* meshes (every edge in two faces, consistently
    oriented, manifold, not self-intersecting; open meshes with their holes
    capped): the sign of ``(p - c) . n`` at the closest point ``c``, with
    ``n`` the angle-weighted pseudo-normal there (exact for such meshes:
    Baerentzen and Aanaes 2005), and CGAL's ``Side_of_triangle_mesh`` where
    that is too close to call and for far points. *Everything else*: the
    generalized winding number ``w`` (Jacobson et al. 2013; Barill et al.
    2018), ``f = clip(4 (1 - 2w), -1, 1) * distance``, whose zero set closes
    holes with the surface ``w = 0.5`` and gives the union of overlapping
    parts. *Badly open* meshes (a flat patch) raise
    :class:`~rdmesh.MeshInputError`: more than 20 % of the area next to
    which ``w`` is farther than 0.25 from a whole number, or caps that
    enclose no volume.

    **What the remesh guarantees** (a run that ends with ``complete=True``; the
    input is piecewise flat, so the smooth-surface theorems do not apply):
    every angle is at least the angle bound (20 degrees next to balls when repairs
    reach it; not enforced next to a rim), every surface Delaunay ball is below
    the size bound, every facet's circumcentre is within the distance bound of
    its surface centre, and every vertex lies on the input (or on what closes a
    hole, with ``holes="fill"``). The distance bound is also measured both ways
    on closed inputs (:mod:`rdmesh.refine.deviation`). Keeping the input's
    topology is sampled, not proven; sharp creases are kept through
    ``feature_angle`` (``SurfaceMesh.features`` reports the check). Razor-thin
    wedges (folds) have no feature size: runs that resolve them end with
    ``complete=False``. The user guide's "Triangle meshes" page has the details.
    """

    def __init__(
        self, mesh: Any, *, name: str = "mesh", feature_angle: Any = "auto", features: Any = None,
        holes: str = "keep",
    ) -> None:  # fmt: skip
        choice("holes", holes, HOLES)
        self.vertices, self.faces, norms, self._normals = oriented_mesh(mesh)
        self.holes, norms = _holes(self, norms, holes, features)
        n = self.input_face_count = len(self.faces)
        norms, (centre, radius) = close_holes(self, norms, bounding_sphere(self.vertices))
        self.fold_edges = fold_edges(self.faces[:n], self._normals[:n])
        self.folds = len(self.fold_edges)
        self._set_sign(norms)
        self._find_self_intersections()
        self.feature_angle, self.sharp_edges, self.sharp_curves = sharp_curves(
            self.vertices, self.faces[:n], _sharp_angle(feature_angle, features)
        )
        super().__init__(
            self._signed_distance, (centre, radius), gradient=self._gradient, name=name,
            features=features,
        )  # fmt: skip


def filled(surface: MeshSurface) -> MeshSurface:
    """``surface``'s input (its slivers trimmed) with the holes filled
    (``holes="fill"``), the same name, feature angle and features."""
    faces = surface.faces[: surface.input_face_count]
    v = surface.vertices if surface.holes is None else surface.vertices[: surface.holes.base]
    angle = surface.feature_angle if len(surface.sharp_edges) else None  # as "auto" chose
    return MeshSurface(
        (v, faces), name=surface.name, feature_angle=angle,
        features=surface.features or None, holes="fill",
    )  # fmt: skip
