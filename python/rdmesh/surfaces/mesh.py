"""Triangle meshes as surfaces: the signed distance to a mesh, for remeshing.

``MeshSurface(mesh)`` is an :class:`~rdmesh.ImplicitSurface` whose ``f`` is
the signed distance to a triangle mesh, so that ``rdmesh.mesh_surface``
remeshes it with the angle bound, the sizing field and the distance bound.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from .._errors import MeshInputError
from .._regions import describe_regions, regions
from .._tol import REGION_LINK
from ..core import MeshDistance
from ..features.sharp_edges import sharp_curves
from .oracle import ImplicitSurface

log = logging.getLogger("rdmesh")

#: The bounding sphere's radius, times the largest distance of a vertex from
#: the centre of the mesh's bounding box.
SPHERE_MARGIN = 1.2
#: Below this distance (times the bounding radius) the gradient is the normal
#: of the closest face: there ``p - closest`` is too short to give a direction.
NORMAL_DISTANCE = 1e-9
#: Open meshes: f = clip(WINDING_SLOPE * (1 - 2 w), -1, 1) * distance, so the
#: sign follows the winding number w thresholded at 0.5, and f stays
#: continuous across the band |w - 0.5| < 1 / (2 WINDING_SLOPE) that spans
#: each hole.
WINDING_SLOPE = 4.0
#: A face is ambiguous when the winding number just outside it is farther
#: than this from a whole number ...
AMBIGUOUS_MARGIN = 0.25
#: ... and an open mesh is refused when ambiguous faces hold more than this
#: share of its area.
MAX_AMBIGUOUS_SHARE = 0.2
#: Faces sampled for that check (a fixed, seeded subset of larger meshes).
AMBIGUITY_SAMPLES = 20_000
#: f is the signed distance clamped to +-DISTANCE_CAP x the bounding radius:
#: points certainly farther (by a k-d tree of the vertices) skip the exact
#: query, which is slowest there (near the medial axis many faces are almost
#: equally far). The zero set and f within the cap are unchanged.
DISTANCE_CAP = 0.1
#: Two faces sharing an edge whose normals differ by more than this (degrees)
#: form a fold: a razor-thin wedge with no feature size (logged as a warning).
FOLD_ANGLE = 150.0
#: Two sheets closer than this (times R) where points were refused are reported.
CLOSE_SHEETS = 0.02
#: Probes along the normal that measure the gap between sheets.
GAP_SAMPLES = 64
#: Points evaluated per call of the C++ core (bounds the temporary arrays).
_CHUNK = 1 << 18


def _as_arrays(mesh: Any) -> tuple[np.ndarray, np.ndarray]:
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


def _clean(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge equal vertices, drop faces that repeat a vertex and unused vertices."""
    v, inverse = np.unique(v, axis=0, return_inverse=True)
    f = inverse.reshape(-1)[f]
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    f = f[keep]
    if len(f) == 0:
        raise MeshInputError("every face of the mesh has zero area (repeated vertices)")
    used, f = np.unique(f, return_inverse=True)
    return v[used], f.reshape(-1, 3).astype(np.int64)


def _area_vectors(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Half the cross product of each face's edges: (m, 3)."""
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    return 0.5 * np.cross(b - a, c - a)


def _points(points: np.ndarray) -> np.ndarray:
    """Query points as a C-contiguous (N, 3) float64 array, checked finite."""
    pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    bad = ~np.isfinite(pts).all(axis=1)
    if bad.any():
        raise ValueError(f"query point {int(np.argmax(bad))} is not finite")
    return pts


def _count_folds(f: np.ndarray, normals: np.ndarray) -> int:
    """Edges of exactly two faces whose normals differ by more than FOLD_ANGLE."""
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    face = np.tile(np.arange(len(f)), 3)
    _, inverse, counts = np.unique(edges, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    pair = counts[inverse] == 2
    order = np.argsort(inverse[pair], kind="stable")
    faces = face[pair][order].reshape(-1, 2)
    cos = np.einsum("ij,ij->i", normals[faces[:, 0]], normals[faces[:, 1]])
    return int(np.count_nonzero(cos < np.cos(np.radians(FOLD_ANGLE))))


def _is_closed_oriented(f: np.ndarray) -> bool:
    """Every edge in exactly two faces, traversed once in each direction."""
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    if len(np.unique(directed, axis=0)) != len(directed):
        return False
    undirected, counts = np.unique(np.sort(directed, axis=1), axis=0, return_counts=True)
    return bool(np.all(counts == 2)) and len(undirected) * 2 == len(directed)


class MeshSurface(ImplicitSurface):
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
        degrees, unless the sharp edges look like noise (at least 50 curves,
        the median one at most 2 edges long, and fewer than 20 % of the edges
        sharp, as on a noisy scan): then none, with a warning. None: none.
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
        ``f`` is clamped to ``[-cap, cap]`` (``0.1 R``; see Notes).
    ambiguous_share : float
        Share of the area next to which the winding number is far from a
        whole number (0 for closed meshes).
    folds : int
        Edges whose two faces' normals differ by more than 150 degrees
        (razor-thin wedges; see Notes). Nonzero counts are logged as a warning.
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
        1 when ``f`` is the clamped signed distance (closed input), so the
        seeding grid skips the nodes whose sign a coarser grid decides;
        None with the winding-number sign.
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
    ``AABB_tree`` (C++, GIL released, vectorised over the query points). The
    gradient is ``sign * (p - closest) / |p - closest|``, the exact gradient
    of the signed distance away from the medial axis; within ``1e-9 R`` of
    the mesh, the normal of the closest face, turned to the outside (each
    face's side is checked with the sign oracle). ``f`` is the signed distance
    clamped to ``+-cap`` (``cap = 0.1 R``): points that a k-d tree of the
    vertices shows to be farther than ``cap`` skip the exact query, which is
    slowest there (near the medial axis many faces are almost equally far).
    The zero set, the sign and ``f`` within ``cap`` of the mesh are
    unchanged; :meth:`signed_distance` is not clamped. All queries may run
    in several threads at once.

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
    every vertex lies on the input (to the root tolerance), and every output
    triangle lies in a surface Delaunay ball centred on the input, so it is
    within the size bound of the input. That the output is within that
    distance of every part of the input, and keeps its topology, is sampled,
    not proven: it holds when the size bound is below the feature size of
    the shape the mesh approximates (scans, organic shapes). Sharp creases
    (CAD models) are kept through ``feature_angle``: each sharp-edge chain is
    covered by protecting balls centred on the input's own edges (the output
    has a vertex at every corner and edges along every chain;
    ``SurfaceMesh.features`` reports the check). Flatter creases come out
    chamfered, by about the distance bound. Razor-thin wedges (two faces
    folded onto each other, as when noise flips a sliver triangle) have no
    feature size at all: if the bounds are fine enough to resolve them, the
    facets whose dual crosses both sheets of a fold need refinement points
    below the spacing floor, which are refused; the mesh is returned with
    ``complete=False`` (or the vertex budget runs out there) and may not be
    closed.
    """

    def __init__(
        self, mesh: Any, *, name: str = "mesh", feature_angle: Any = "auto", features: Any = None
    ) -> None:
        v, f = _clean(*_as_arrays(mesh))
        area = _area_vectors(v, f)
        if not np.any(np.linalg.norm(area, axis=1) > 0):
            raise MeshInputError("every face of the mesh has zero area")
        volume = float(np.einsum("ij,ij->", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]]))) / 6
        if volume < 0:
            f = f[:, ::-1].copy()
            area = -area
        self.vertices, self.faces = v, f
        norms = np.linalg.norm(area, axis=1)
        self._normals = area / np.where(norms > 0, norms, 1.0)[:, None]
        try:
            self._core = MeshDistance(v, f, side=_is_closed_oriented(f))
        except ValueError as exc:
            raise MeshInputError(str(exc)) from None
        lo, hi = v.min(axis=0), v.max(axis=0)
        centre = 0.5 * (lo + hi)
        extent = float(np.sqrt(((v - centre) ** 2).sum(axis=1).max()))
        radius = SPHERE_MARGIN * max(extent, 1e-12 * (1 + float(np.abs(centre).max())))
        self.cap = DISTANCE_CAP * radius
        edges = np.linalg.norm(v[f] - v[np.roll(f, 1, axis=1)], axis=2)
        # Every point of the mesh is within this of a vertex (a face's
        # circumradius or half its longest edge, both <= longest edge / sqrt 3).
        self._vertex_gap = float(edges.max()) / np.sqrt(3.0)
        self._kdtree = cKDTree(v)
        self.folds = _count_folds(f, self._normals)
        if self.folds:
            log.warning(
                "MeshSurface: %d folds (neighbouring faces at more than %g degrees): "
                "razor-thin wedges with no feature size; bounds fine enough to resolve "
                "them end at the spacing floor (complete=False) or the vertex budget",
                self.folds,
                FOLD_ANGLE,
            )
        #: f is this-Lipschitz (the clamped signed distance), or None (winding sign).
        self.lipschitz: float | None = None
        #: The gradient is a unit vector wherever f is differentiable.
        self.unit_gradient = False
        if self._core.has_side:
            self.sign_method = "side"
            self.ambiguous_share = 0.0
            self.lipschitz, self.unit_gradient = 1.0, True
        else:
            self.sign_method = "winding"
            self.ambiguous_share = self._ambiguity(v, f, norms)
            why = self._core.side_failure or "the mesh is not closed"
            log.info("MeshSurface: %s; the sign comes from the winding number", why)
            if self.ambiguous_share > MAX_AMBIGUOUS_SHARE:
                raise MeshInputError(
                    "the mesh is too open to tell inside from outside: the winding number "
                    f"is far from a whole number next to {100 * self.ambiguous_share:.0f}% of "
                    f"its area (at most {100 * MAX_AMBIGUOUS_SHARE:.0f}% allowed); close its "
                    "holes or orient its faces consistently"
                )
            if self.ambiguous_share > 0:
                log.warning(
                    "MeshSurface: the winding number is ambiguous next to %.2g%% of the "
                    "mesh's area (holes or flipped faces); holes are closed by the surface "
                    "w = 0.5",
                    100 * self.ambiguous_share,
                )
        self._orient_normals(v, f, norms)
        self._find_self_intersections()
        off = isinstance(features, str) and features == "none"
        self.feature_angle, self.sharp_edges, self.sharp_curves = sharp_curves(
            v, f, None if off else feature_angle
        )
        super().__init__(
            self._signed_distance, (centre, radius), gradient=self._gradient, name=name,
            features=features,
        )  # fmt: skip

    def _find_self_intersections(self) -> None:
        """``self_intersections``: the pairs of faces that cross (CGAL's
        Polygon_mesh_processing::self_intersections), for closed manifold inputs."""
        self.self_intersections = self._core.self_intersections()
        if len(self.self_intersections):
            where = self.vertices[self.faces[self.self_intersections[:, 0]]].mean(axis=1)
            log.warning(
                "MeshSurface: the mesh intersects itself (%d pairs of faces cross, %s); "
                "its topology is not that of a surface: the remesh follows the union of "
                "what it encloses (winding number) and is marked incomplete",
                len(self.self_intersections),
                describe_regions(regions(where, REGION_LINK * float(np.ptp(self.vertices)))),
            )

    def input_report(self, unresolved: np.ndarray | None = None) -> dict | None:
        """What in the input stands in the way of its topology, for the mesh's report.

        Parameters
        ----------
        unresolved : (k, 3) array, optional
            The run's refused refinement points: where two sheets of the
            input are closer than refinement can separate, the gap is
            measured there.

        Returns
        -------
        dict or None
            ``self_intersections`` (``pairs``, ``regions``) when the input
            intersects itself, ``close_sheets`` (``gap``, ``regions``) when
            refused points lie where two sheets of the input nearly touch,
            ``incomplete`` (the input alone rules out its topology) and a
            ``statement``; None when there is nothing to say.
        """
        out: dict = {"incomplete": False}
        said = []
        pairs = self.self_intersections
        if len(pairs):
            where = self.vertices[self.faces[pairs[:, 0]]].mean(axis=1)
            found = regions(where, REGION_LINK * self.radius)
            out["self_intersections"] = {"pairs": len(pairs), "regions": found}
            out["incomplete"] = True
            said.append(
                f"the input mesh intersects itself ({len(pairs)} pairs of faces cross, "
                f"{describe_regions(found)}): it bounds no solid with its topology, so the "
                "remesh (of the union it encloses, by the winding number) cannot keep it"
            )
        if unresolved is not None and len(unresolved):
            gap = self.sheet_gap(unresolved)
            close = gap < CLOSE_SHEETS * self.radius
            if close.any():
                found = regions(unresolved[close], REGION_LINK * self.radius)
                out["close_sheets"] = {
                    "points": int(close.sum()),
                    "gap": float(np.median(gap[close])),
                    "regions": found,
                }
                said.append(
                    f"two sheets of the input nearly touch where {int(close.sum())} refinement "
                    f"points were refused (median gap {np.median(gap[close]):.3g}, "
                    f"{describe_regions(found)}): closer than the spacing floor lets "
                    "refinement separate them"
                )
        if not said:
            return None
        out["statement"] = "; ".join(said)
        return out

    def sheet_gap(self, points: np.ndarray) -> np.ndarray:
        """Distance across the thinnest part (inside or outside) of the input at
        points on it, ``(k,)``: twice the distance from the point to the
        medial axis along the closest face's normal, sampled up to
        ``CLOSE_SHEETS * R`` (that value where it is farther)."""
        closest, face = self.closest_points(points)
        n = self._normals[face]
        t = np.linspace(0.0, CLOSE_SHEETS * self.radius, GAP_SAMPLES + 1)[1:]
        gaps = []
        for sign in (1.0, -1.0):
            probe = closest[None] + sign * t[:, None, None] * n[None]
            d = np.abs(self.signed_distance(probe.reshape(-1, 3))).reshape(len(t), -1)
            # Beyond the medial axis the distance falls below the probe's offset.
            behind = d < t[:, None] * (1 - 1e-6)
            first = np.where(behind.any(axis=0), np.argmax(behind, axis=0), len(t) - 1)
            gaps.append(2.0 * t[first])
        return np.minimum(*gaps)

    def _orient_normals(self, v: np.ndarray, f: np.ndarray, norms: np.ndarray) -> None:
        """Flip the normals (used for the gradient on the mesh) of faces whose front is inside.

        Components oriented against the rest, or faces flipped in an open mesh,
        would otherwise give a gradient pointing inwards right on the surface.
        """
        idx = np.flatnonzero(norms > 0)
        probe = v[f[idx]].mean(axis=1) + 1e-3 * np.sqrt(norms[idx])[:, None] * self._normals[idx]
        self._normals[idx[self._sign(probe) < 0]] *= -1

    def _ambiguity(self, v: np.ndarray, f: np.ndarray, norms: np.ndarray) -> float:
        """Share of the area next to which the winding number is not near a whole number."""
        idx = np.flatnonzero(norms > 0)
        if len(idx) > AMBIGUITY_SAMPLES:
            idx = np.sort(np.random.default_rng(0).choice(idx, AMBIGUITY_SAMPLES, replace=False))
        centroid = v[f[idx]].mean(axis=1)
        step = 1e-3 * np.sqrt(norms[idx])
        w = self._core.winding_number(centroid + step[:, None] * self._normals[idx])
        ambiguous = np.abs(w - np.round(w)) > AMBIGUOUS_MARGIN
        return float(norms[idx][ambiguous].sum() / norms[idx].sum())

    # -- the oracle ----------------------------------------------------------------

    def _query(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Distance, closest point, closest face and sign factor s in [-1, 1]."""
        parts = [self._core.query(pts[i : i + _CHUNK]) for i in range(0, len(pts), _CHUNK)]
        if len(parts) == 1:
            dist, closest, face, side = parts[0]
        else:
            dist, closest, face, side = (np.concatenate(x) for x in zip(*parts, strict=True))
        s = side.astype(np.float64) if self.sign_method == "side" else self._winding_factor(pts)
        return dist, closest, face, s

    def _winding_factor(self, pts: np.ndarray) -> np.ndarray:
        w = np.concatenate(
            [self._core.winding_number(pts[i : i + _CHUNK]) for i in range(0, len(pts), _CHUNK)]
        )
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
        if len(pts) == 0:
            return np.zeros((0, 3))
        dist, closest, face, s = self._query(pts)
        near = dist <= NORMAL_DISTANCE * self.radius
        g = np.empty_like(pts)
        far = ~near
        # Outside s = 1 and p - closest points out; inside s = -1 and it points in.
        g[far] = np.sign(s[far])[:, None] * (pts[far] - closest[far]) / dist[far, None]
        g[near] = self._normals[face[near]]
        band = far & (np.abs(s) < 1.0)
        if band.any():
            # Open meshes, across a hole: f = s(w) d, so grad f = s grad d + d grad s,
            # with grad s from central differences of w (smooth there: no face within d).
            p, d = pts[band], dist[band]
            h = np.clip(0.1 * d, NORMAL_DISTANCE * self.radius, 1e-4 * self.radius)
            step = h[None, :, None] * np.eye(3)[:, None, :]
            probes = np.concatenate([p[None] + step, p[None] - step])
            sw = self._winding_factor(probes.reshape(-1, 3)).reshape(2, 3, -1)
            grad_s = ((sw[0] - sw[1]) / (2 * h)).T
            unit = (p - closest[band]) / d[:, None]
            g[band] = s[band, None] * unit + d[:, None] * grad_s
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
        _, closest, face, _ = self._query(pts)
        return closest, face

    def winding_number(self, points: np.ndarray) -> np.ndarray:
        """Generalized winding number of the mesh at ``(N, 3)`` points: ``(N,)``."""
        pts = _points(points)
        return self._core.winding_number(pts)
