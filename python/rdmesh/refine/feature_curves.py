"""Where feature curves come from: the user's polylines, the curve where a
clipped surface meets its domain, the creases of a volume closed by its
box, and the creases found in an expression or CSG tree (each a
:class:`~rdmesh.features.graph.FeatureGraph`)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .._vectors import row_norms
from ..creases.search import CreaseSearch, find_creases, piece_model
from ..features.graph import (
    FeatureCurve,
    FeatureError,
    FeatureGraph,
    as_polylines,
    build_graph,
    curve_of_polyline,
    given_curves,
)
from ..sampling.boundary import BoundaryCurve, project_onto_curve
from ..surfaces._mesh_holes import RIM_SOURCE
from ..surfaces.trilinear_kinks import KINK_SOURCE, kink_curves

#: A given curve's points must lie within this of the surface (|f| / |grad f|), times R.
ON_SURFACE = 1e-6


def has_given_curves(surface) -> bool:
    """Whether the user gave ``surface`` feature polylines (``features=[...]``)."""
    return isinstance(surface.features, list) and len(surface.features) > 0


def check_on_surface(surface, curves: list[FeatureCurve]) -> None:
    """FeatureError naming the first given curve with a point off the surface."""
    given = [c for c in curves if c.source == "given"]
    if not given:
        return
    pts = np.concatenate([c.points for c in given])
    owner = np.concatenate([np.full(len(c.points), i) for i, c in enumerate(given)])
    f = surface(pts)
    g = row_norms(surface.grad(pts))
    dist = np.abs(f) / np.maximum(g, 1e-300)
    off = dist > ON_SURFACE * surface.radius
    if off.any():
        k = int(np.argmax(off))
        c = given[owner[k]]
        raise FeatureError(
            f"{c.label} is not on the surface: its point {np.round(pts[k], 9).tolist()} has "
            f"f = {f[k]:.3g}, about {dist[k]:.3g} from the surface (at most "
            f"{ON_SURFACE * surface.radius:.3g} is allowed)"
        )


def boundary_curves(surface, curve: BoundaryCurve) -> list[FeatureCurve]:
    """The traced curve where a clipped surface meets its sphere or box, as
    curves split at its corners (box edges), projected exactly onto the curve
    (Newton within the sphere or the box face)."""

    def project(x: np.ndarray) -> np.ndarray:
        return project_onto_curve(surface, x)

    return _loops_as_curves(curve, project, "clip boundary")


def _loops_as_curves(curve: BoundaryCurve, project: Callable, source: str) -> list[FeatureCurve]:
    """Each traced loop of ``curve`` as a closed curve, or as open curves from
    corner to corner (``curve.corners``) when it has any."""
    out = []
    dense, loop = curve.dense, curve.dense_loop
    corners = curve.corners
    for k in range(curve.n_loops):
        pts = dense[loop == k]
        at = np.zeros(len(pts), bool)
        if len(corners) and len(pts):
            at = _nearest(pts, corners) <= 1e-9 * max(curve.spacing, 1e-300)
        # Crossings of grid edges around one grid point can be closer than
        # rounding: one of them is enough (corners are kept).
        pts, at = _thin(pts, at, THIN * curve.spacing)
        if len(pts) < 3:
            continue
        label = f"{source} loop {k}"
        if not at.any():
            out.append(FeatureCurve(pts, True, source, project, label))
            continue
        # Open pieces from corner to corner, the loop turned to start at one.
        first = int(np.argmax(at))
        pts, at = np.roll(pts, -first, axis=0), np.roll(at, -first)
        cut = np.flatnonzero(at)
        bounds = np.r_[cut, len(pts)]
        for j in range(len(cut)):
            a, b = bounds[j], bounds[j + 1]
            piece = np.concatenate([pts[a:b], pts[b % len(pts)][None]])
            if len(piece) >= 2:
                out.append(FeatureCurve(piece, False, source, project, f"{label} piece {j}"))
    return out


#: Traced curve points closer than this, times the tracing grid's spacing, are one.
THIN = 1e-3


def _thin(pts: np.ndarray, keep: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """A closed polyline without points within ``tol`` of the previous kept one
    (``keep`` marks points that stay)."""
    if len(pts) < 2:
        return pts, keep
    step = row_norms(pts - np.roll(pts, 1, axis=0))
    # Runs of close points: keep each run's first point (or its kept one).
    ok = (step > tol) | keep
    if not ok.any():
        ok[0] = True
    return pts[ok], keep[ok]


def _nearest(pts: np.ndarray, corners: np.ndarray) -> np.ndarray:
    from scipy.spatial import cKDTree

    return cKDTree(corners).query(pts)[0]


def volume_box_curves(volume, curve: BoundaryCurve) -> tuple[list[FeatureCurve], np.ndarray]:
    """The creases of a volume closed by its box: where the isosurface meets
    the box faces (``curve``, traced on the box for ``f_volume``), and the
    parts of the box's edges inside the region, from corner to corner.
    Returns the curves and the box corners inside the region."""
    from ..surfaces.oracle import ImplicitSurface

    clipped = ImplicitSurface(
        volume.f_volume, volume.bounding_sphere, gradient=volume._volume_gradient,
        clip_box=volume.box,
    )  # fmt: skip

    def project(x: np.ndarray) -> np.ndarray:
        return project_onto_curve(clipped, x)

    curves = _loops_as_curves(curve, project, "volume box")
    lo, hi = volume.box
    box_corners = np.array([[(lo, hi)[(k >> a) & 1][a] for a in range(3)] for k in range(8)])
    inside_corner = volume.f_volume(box_corners) < 0
    edges = []
    for a in range(8):
        for axis in range(3):
            if (a >> axis) & 1:
                continue
            b = a | (1 << axis)
            edges.append((a, b, axis))
    crossings = curve.corners
    for a, b, axis in edges:
        p, q = box_corners[a], box_corners[b]
        # The crossings of f_volume = 0 on this edge, in order along it.
        other = [k for k in range(3) if k != axis]
        if len(crossings):
            on = (np.abs(crossings[:, other[0]] - p[other[0]]) <= 1e-12 * volume.radius) & (
                np.abs(crossings[:, other[1]] - p[other[1]]) <= 1e-12 * volume.radius
            )
            t = np.sort((crossings[on, axis] - p[axis]) / (q[axis] - p[axis]))
        else:
            t = np.zeros(0)
        stops = np.r_[0.0, t, 1.0]
        mids = 0.5 * (stops[1:] + stops[:-1])
        inside = volume.f_volume(p + mids[:, None] * (q - p)) < 0
        for j in np.flatnonzero(inside):
            seg = p + np.array([stops[j], stops[j + 1]])[:, None] * (q - p)
            if row_norms(seg[1:] - seg[:1])[0] > 0:
                label = f"box edge {a}-{b} piece {j}"
                curves.append(FeatureCurve(seg, False, "box edge", None, label))
    return curves, box_corners[inside_corner]


def feature_graph(
    surface,
    *,
    boundary: BoundaryCurve | None = None,
    volume_curve: BoundaryCurve | None = None,
    creases: CreaseSearch | None = None,
) -> FeatureGraph:
    """Every feature curve of a surface: its given polylines, its clip
    boundary (``boundary``, traced), for a volume closed by its box, the
    box's creases (``volume_curve``, traced on the box), and the creases
    found in its expression or CSG tree (``creases``:
    :func:`~rdmesh.creases.search.find_creases`)."""
    R = surface.radius
    curves = given_curves(as_polylines(getattr(surface, "features", None)), R)
    if creases is not None:
        curves += creases.curves
    for k, p in enumerate(getattr(surface, "sharp_curves", [])):
        # The mesh's own edges: the polyline is the curve.
        curves.append(curve_of_polyline(p, R, f"sharp edges {k}", "mesh"))
    holes = getattr(surface, "holes", None)
    for k, p in enumerate(holes.curves if holes is not None else []):
        # An open mesh's rims, kept (the caps are cut off along them).
        curves.append(curve_of_polyline(p, R, f"hole rim {k}", RIM_SOURCE))
    extra = np.zeros((0, 3))
    if boundary is not None and len(boundary.dense):
        curves += boundary_curves(surface, boundary)
    if volume_curve is not None:
        more, extra = volume_box_curves(surface, volume_curve)
        curves += more
    if getattr(surface, "interpolation", None) == "linear":
        curves += kink_curves(surface)
    if not curves and not len(extra):
        return FeatureGraph()
    return build_graph(curves, R, extra)


#: Kink curves within this many grid spacings of a place that cannot be
#: protected are left out there.
KINK_DROP = 2.0


def without_kinks_near(
    graph: FeatureGraph, where: np.ndarray | None, radius: float, spacing: float
) -> FeatureGraph | None:
    """The graph without its volume kink curves within :data:`KINK_DROP`
    grid spacings of ``where``; None when there is no place or no such curve
    (the failure is another curve's). Corners that end no curve (a closed
    volume's box corners) stay."""
    if where is None:
        return None
    near = np.array([
        c.source == KINK_SOURCE and float(row_norms(c.points - where).min()) <= KINK_DROP * spacing
        for c in graph.curves
    ], bool)  # fmt: skip
    if not near.any():
        return None
    rest = [c for c, n in zip(graph.curves, near, strict=True) if not n]
    isolated = graph.corners[~graph.ended]
    return build_graph(rest, radius, isolated) if rest else FeatureGraph(corners=isolated)


def kink_balls(plan) -> tuple[np.ndarray, np.ndarray] | None:
    """A plan's ball centres and which of them lie on volume kink curves
    only (for :func:`repair_sites`); None without balls."""
    graph, balls = plan.features, plan.balls
    if graph is None or balls is None or not len(balls):
        return None
    kink = np.array([c.source == KINK_SOURCE for c in graph.curves] + [False], bool)
    soft = kink[np.where(balls.curve >= 0, balls.curve, len(graph.curves))]
    # A corner is soft when every curve ending at it is a kink curve.
    corner = balls.corner >= 0
    soft[corner] = (graph.ended & ~graph.ended_by(~kink[:-1]))[balls.corner[corner]]
    return balls.centres, soft


def search_creases(surface, topology: str, seed: int, resolution: int) -> CreaseSearch | None:
    """The creases of a surface whose function is an expression or a CSG tree
    (:func:`~rdmesh.creases.search.find_creases`), unless its
    features are given or off; None when there is nothing to search. A
    surface with a boundary (a clip box, or ``topology="manifold-with-boundary"``)
    is not searched: creases that reach the boundary are not followed onto
    it yet (the report says so)."""
    features = getattr(surface, "features", None)
    if features == "none" or (isinstance(features, list) and features):
        return None
    if topology == "manifold-with-boundary" or getattr(surface, "clip_box", None) is not None:
        if piece_model(surface) is None:
            return None
        return CreaseSearch(note="not searched: creases are not followed onto a boundary yet")
    return find_creases(surface, seed=seed, resolution=resolution)


__all__ = [
    "FeatureError",
    "check_on_surface",
    "feature_graph",
    "has_given_curves",
    "search_creases",
]
