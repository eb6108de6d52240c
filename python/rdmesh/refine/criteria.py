"""Facet criteria of CGAL's Surface_mesh_default_criteria_3, vectorised.

A restricted facet is bad when its smallest angle is below the angle bound, its
surface Delaunay ball is larger than the sizing field at the ball's centre, or
its circumcentre is farther than the distance bound from its surface centre.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .._geometry import circumcentres, circumradii, cross, min_angles, sin2_min_angle  # noqa: F401

Sizing = Callable[[np.ndarray], np.ndarray]

#: Above this angle bound Delaunay refinement is not known to terminate.
MAX_ANGLE_BOUND = 30.0


def _positive(name: str, value) -> float | None:
    if value is None:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, a callable or None, got {value!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise ValueError(f"{name} must be positive and finite, got {value!r}")
    return v


@dataclass(frozen=True)
class FacetCriteria:
    """Bounds that every output facet satisfies.

    Parameters
    ----------
    angle_bound : float
        Smallest allowed triangle angle in degrees, in ``[0, 30]``; 0 disables it.
    radius_bound : float or callable or None
        Largest surface Delaunay ball radius, a number or a sizing field mapping
        ``(N, 3)`` points to ``N`` positive radii; None disables it.
    distance_bound : float or None
        Largest distance between a facet's circumcentre and its surface centre.
    hold_at_small_balls : bool
        Hold the angle bound next to protecting balls of at most
        :data:`SMALL_BALL` times the radius bound (see :func:`_held`); set
        where the balls are at most that far apart (``edge_size``, given or
        by default: :mod:`rdmesh.refine.ball_spacing`).
    local_bound : callable or None
        A sizing field that lowers the radius bound where it is smaller (near
        a mesh input's thin parts: :mod:`rdmesh.surfaces._mesh_thin`).
    """

    angle_bound: float = 30.0
    radius_bound: float | Sizing | None = None
    distance_bound: float | None = None
    hold_at_small_balls: bool = False
    local_bound: Sizing | None = None

    def __post_init__(self) -> None:
        try:
            a = float(self.angle_bound)
        except (TypeError, ValueError):
            raise ValueError(f"angle_bound must be a number, got {self.angle_bound!r}") from None
        if not math.isfinite(a) or a < 0:
            raise ValueError(f"angle_bound must be finite and >= 0, got {self.angle_bound!r}")
        if a > MAX_ANGLE_BOUND:
            raise ValueError(
                f"angle_bound {a} is above {MAX_ANGLE_BOUND} degrees, where refinement "
                "is not guaranteed to terminate"
            )
        object.__setattr__(self, "angle_bound", a)
        if not callable(self.radius_bound):
            object.__setattr__(self, "radius_bound", _positive("radius_bound", self.radius_bound))
        object.__setattr__(
            self, "distance_bound", _positive("distance_bound", self.distance_bound)
        )

    def sizing(self, centres: np.ndarray) -> np.ndarray | None:
        """The radius bound at ``(k, 3)`` centres, or None when there is none."""
        if self.radius_bound is None:
            return None
        psi = self._user_sizing(centres)
        return psi if self.local_bound is None else np.minimum(psi, self.local_bound(centres))

    def _user_sizing(self, centres: np.ndarray) -> np.ndarray:
        """The radius bound (a number or the user's field, checked) at ``centres``."""
        if not callable(self.radius_bound):
            return np.full(len(centres), self.radius_bound)
        try:
            psi = np.asarray(self.radius_bound(centres), dtype=np.float64)
        except Exception as exc:  # noqa: BLE001 - user code
            raise ValueError(
                f"the radius_bound sizing field raised {type(exc).__name__}: {exc}"
            ) from exc
        if psi.shape != (len(centres),) or not np.all(np.isfinite(psi)) or np.any(psi <= 0):
            raise ValueError(
                "the radius_bound sizing field must return one positive finite radius per point"
            )
        return psi

    def bad(
        self,
        corners: np.ndarray,
        centres: np.ndarray,
        radii: np.ndarray,
        angle_exempt: np.ndarray | None = None,
        weights: np.ndarray | None = None,
        slack: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> np.ndarray:
        """Which facets fail a criterion.

        Parameters
        ----------
        corners : (k, 3, 3) facet vertex coordinates.
        centres : (k, 3) surface centres.
        radii : (k,) surface Delaunay ball radii (power radii).
        angle_exempt : (k,) bool, optional
            Facets the angle bound does not apply to (on a clipped surface
            without protecting balls, those with two or three vertices on the
            bounding sphere).
        weights : (k, 3) float, optional
            The weights of the facet's vertices (protecting balls: radius
            squared; samples: 0). Facets next to balls get Mesh_3's
            relaxation (:func:`relaxed`); the distance is measured from the
            weighted circumcentre.
        slack : ((k,) float, (k,) float), optional
            Least size and distance bounds (where the output is cut off
            afterwards: :func:`rdmesh.surfaces._mesh_tents.tent_slack`).

        Returns
        -------
        (k,) bool
        """
        bad = np.zeros(len(corners), dtype=bool)
        if len(corners) == 0:
            return bad
        skip = None
        if weights is not None and np.any(weights > 0):
            skip = relaxed(corners, weights)
        psi = self.sizing(centres)
        if self.angle_bound > 0:
            sin2 = sin2_min_angle(corners)
            skinny = sin2 < math.sin(math.radians(self.angle_bound)) ** 2
            if angle_exempt is not None:
                skinny &= ~angle_exempt
            if skip is not None:
                small = psi if self.hold_at_small_balls else None
                skinny &= ~skip.angle | _held(sin2, self.angle_bound, radii, weights, small)
            bad |= skinny
        if psi is not None:
            if slack is not None:
                psi = np.maximum(psi, slack[0])
            large = radii > psi
            bad |= large if skip is None else large & ~skip.size
        if self.distance_bound is not None:
            cc = (
                circumcentres(corners)
                if skip is None
                else weighted_circumcentres(corners, weights)
            )
            bound = self.distance_bound
            if slack is not None:
                bound = np.maximum(bound, slack[1])
            far = np.linalg.norm(cc - centres, axis=1) > bound
            bad |= far if skip is None else far & ~skip.distance
        if skip is not None:
            bad &= ~skip.never
        return bad


@dataclass(frozen=True)
class Relaxed:
    """Which criteria a facet next to protecting balls is spared (each (k,) bool)."""

    distance: np.ndarray
    angle: np.ndarray
    size: np.ndarray
    #: Three balls that share a point: the facet is never refined.
    never: np.ndarray


#: Mesh_3's thresholds (``Facet_criterion_visitor_with_features``): a facet
#: with one weighted vertex (or two whose balls meet) is spared the distance,
#: angle and size criteria while the squared radius of the smallest sphere
#: orthogonal to its ball and another vertex, over the ball's weight, is below
#: these.
RELAX_DISTANCE, RELAX_ANGLE, RELAX_SIZE = 0.1**2 * 4, 0.5**2 * 4, 0.4**2 * 4
#: Where Mesh_3 drops the angle bound next to a ball, rdmesh keeps this one
#: (degrees) for facets whose surface ball is at least RELAXED_FLOOR times the
#: largest protecting ball among their vertices.
RELAXED_ANGLE, RELAXED_FLOOR = 20.0, 0.25


#: Where the balls are at most SMALL_BALL times the radius bound apart
#: (``edge_size``), next to a protecting ball of radius at most SMALL_BALL
#: times the radius bound there, the full angle bound is held for facets whose
#: surface ball is at least HOLD_RATIO times the ball's radius. Their
#: refinement point lies at least sqrt(1 + HOLD_RATIO**2) ball radii from the
#: ball's centre, so it does not split the angle at the centre into thinner
#: ones (below about 0.6 of the radius it does, and refinement there ends only
#: at the relaxed bound). On the thin-handled genus-2 benchmark solid, with
#: balls 0.3 of the radius bound apart, 30 degrees held at 1 % and 0.3 % of
#: the diagonal; with HOLD_RATIO 0.35, the CAD shapes' smallest angles fell to
#: 12-13 degrees.
#: Not with balls a radius bound apart: next to their small corner balls it
#: changed the CAD meshes (fillet_chamfer: 21.1 degrees against 24.2).
SMALL_BALL, HOLD_RATIO = 0.3, 0.7


def _held(sin2, bound: float, radii, weights, psi) -> np.ndarray:
    """(k,) bool: facets next to protecting balls whose smallest angle
    (``sin2``: its sine squared) is held: below :data:`RELAXED_ANGLE` (or
    ``bound`` if lower) while the facet's ball is not small against the
    protecting ball (so refinement there ends: each point is that far from
    every vertex), or below ``bound`` next to small balls (:data:`SMALL_BALL`
    times ``psi``, the radius bound at the facets; None: not held there)."""
    rho = np.sqrt(weights.max(axis=1))
    floor = min(bound, RELAXED_ANGLE)
    held = (sin2 < math.sin(math.radians(floor)) ** 2) & (radii >= RELAXED_FLOOR * rho)
    if psi is not None:
        held |= (rho <= SMALL_BALL * psi) & (radii >= HOLD_RATIO * rho)
    return held


def relaxed(corners: np.ndarray, weights: np.ndarray) -> Relaxed:
    """Mesh_3's relaxation of the facet criteria next to protecting balls.

    Parameters
    ----------
    corners : (k, 3, 3) facet vertices.
    weights : (k, 3) their weights.
    """
    k = len(corners)
    w = np.asarray(weights, dtype=np.float64)
    heavy = w > 0
    n = heavy.sum(axis=1)
    # The weighted vertices first (stable: the order among them is kept).
    order = np.argsort(~heavy, axis=1, kind="stable")
    rows = np.arange(k)[:, None]
    p, wp = corners[rows, order], w[rows, order]
    with np.errstate(divide="ignore", invalid="ignore"):
        r12 = _orthogonal_sq_radius(p[:, 0], wp[:, 0], p[:, 1], wp[:, 1])
        r13 = _orthogonal_sq_radius(p[:, 0], wp[:, 0], p[:, 2], wp[:, 2])
        r23 = _orthogonal_sq_radius(p[:, 1], wp[:, 1], p[:, 2], wp[:, 2])
        one = np.maximum(r12, r13) / wp[:, 0]
        two = np.maximum(r13 / wp[:, 0], r23 / wp[:, 1])
    ratio = np.where(n == 1, one, np.where(n == 2, two, np.inf))
    ratio = np.where(np.isfinite(ratio), ratio, np.inf)
    meet = np.zeros(k, bool)
    meet[n == 2] = r12[n == 2] <= 0
    three = n == 3
    if three.any():
        meet[three] = _orthogonal_sq_radius3(p[three], wp[three]) <= 0
    applies = (n == 1) | ((n == 2) & meet)
    return Relaxed(
        distance=applies & (ratio < RELAX_DISTANCE),
        angle=applies & (ratio < RELAX_ANGLE),
        size=applies & (ratio < RELAX_SIZE),
        never=three & meet,
    )


def _orthogonal_sq_radius(p, wp, q, wq) -> np.ndarray:
    """Squared radius of the smallest sphere orthogonal to two weighted points
    (row-wise): negative when their balls overlap."""
    d2 = np.einsum("ij,ij->i", q - p, q - p)
    return (d2 + wp - wq) ** 2 / (4.0 * d2) - wp


def _orthogonal_sq_radius3(p: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Squared radius of the smallest sphere orthogonal to three weighted
    points ``(k, 3, 3)``, weights ``(k, 3)``: negative when their balls share a point."""
    x = weighted_circumcentres(p, w)
    d = x - p[:, 0]
    return np.einsum("ij,ij->i", d, d) - w[:, 0]


def weighted_circumcentres(corners: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The point of each triangle's plane with equal power to its three
    weighted vertices, ``(k, 3, 3), (k, 3) -> (k, 3)`` (the circumcentre when
    the weights are 0)."""
    a = corners[:, 0]
    u, v = corners[:, 1] - a, corners[:, 2] - a
    bu = 0.5 * (np.einsum("ij,ij->i", u, u) - (weights[:, 1] - weights[:, 0]))
    bv = 0.5 * (np.einsum("ij,ij->i", v, v) - (weights[:, 2] - weights[:, 0]))
    uu = np.einsum("ij,ij->i", u, u)
    vv = np.einsum("ij,ij->i", v, v)
    uv = np.einsum("ij,ij->i", u, v)
    det = uu * vv - uv * uv
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (bu * vv - bv * uv) / det
        t = (bv * uu - bu * uv) / det
    return a + s[:, None] * u + t[:, None] * v
