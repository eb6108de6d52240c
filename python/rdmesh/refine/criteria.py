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
    """

    angle_bound: float = 30.0
    radius_bound: float | Sizing | None = None
    distance_bound: float | None = None

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
    ) -> np.ndarray:
        """Which facets fail a criterion.

        Parameters
        ----------
        corners : (k, 3, 3) facet vertex coordinates.
        centres : (k, 3) surface centres.
        radii : (k,) surface Delaunay ball radii.
        angle_exempt : (k,) bool, optional
            Facets the angle bound does not apply to (on a clipped surface,
            those with two or three vertices on the bounding sphere).

        Returns
        -------
        (k,) bool
        """
        bad = np.zeros(len(corners), dtype=bool)
        if len(corners) == 0:
            return bad
        if self.angle_bound > 0:
            skinny = sin2_min_angle(corners) < math.sin(math.radians(self.angle_bound)) ** 2
            if angle_exempt is not None:
                skinny &= ~angle_exempt
            bad |= skinny
        psi = self.sizing(centres)
        if psi is not None:
            bad |= radii > psi
        if self.distance_bound is not None:
            d = np.linalg.norm(circumcentres(corners) - centres, axis=1)
            bad |= d > self.distance_bound
        return bad
