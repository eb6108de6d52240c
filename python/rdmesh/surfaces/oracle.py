"""Surface oracles: a vectorised implicit function plus its bounding sphere."""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._errors import OracleError
from .._tol import GRADIENT_STEP
from .._validate import box_in_sphere, sphere

ArrayFunction = Callable[[np.ndarray], np.ndarray]

# Larger arrays are evaluated in pieces so that memory stays bounded.
_CHUNK = 1 << 22


@dataclass
class ImplicitSurface:
    """The surface ``f(x, y, z) = 0`` inside a bounding sphere, ``f < 0`` inside.

    Parameters
    ----------
    f : callable
        Maps an ``(N, 3)`` float array of points to ``N`` values. It is always
        called on large arrays, never point by point.
    bounding_sphere : (centre, radius)
        A sphere that strictly contains the surface. ``f`` must be positive on
        and outside it, unless the surface is meshed with a boundary
        (``topology="manifold-with-boundary"``, or a ``clip_box``, which the
        sphere must contain).
    gradient : callable, optional
        Maps ``(N, 3)`` points to ``(N, 3)`` gradients of ``f``. Without it,
        central finite differences are used.
    name : str, optional
        A label for logs and reports.
    clip_box : (2, 3) array_like, optional
        Mesh only the part of the surface inside this axis-aligned box: its
        lowest corner ``(x0, y0, z0)`` and highest corner ``(x1, y1, z1)``,
        finite, with ``x0 < x1``, ``y0 < y1``, ``z0 < z1``, and strictly
        inside the bounding sphere. The surface may then cross the box
        faces (and the sphere): :func:`rdmesh.mesh_surface` meshes the part
        inside the box, with a boundary on its faces, with
        ``topology="manifold-with-boundary"`` (the default for such a
        surface; other topologies, ``method="topological-ball"`` and
        ``certify=True`` raise ValueError). Default None: no box, the bounding ball only.
    features : list of (m, 3) array_like, or "none", optional
        Feature curves to keep in the mesh (creases, sharp edges), each a
        polyline of points on the surface in order along the curve; a curve
        whose last point repeats its first is a closed loop. Curves may meet
        only at their end points (those are the corners); an end point on
        another curve's interior splits that curve there. The mesh then has
        a vertex at every corner and its edges follow each curve (protecting
        balls centred on the polyline: :mod:`rdmesh.features`). Curves the
        domain makes (where a ``clip_box`` or the bounding sphere cuts the
        surface, the box of a closed volume, a mesh's sharp edges) are
        protected as well. Default None: only those; "none": nothing is
        protected (clip boundaries are then snapped, creases chamfered).
        Balls placed beforehand (:class:`rdmesh.features.ProtectingBalls`) replace all of these.

    Attributes
    ----------
    centre : (3,) float64
    radius : float
        The bounding sphere's centre and radius.
    clip_box : (2, 3) float64 or None
        The checked box (a copy), or None. It may be reassigned;
        :func:`rdmesh.mesh_surface` checks it again.
    evaluations : int
        The number of points evaluated so far.

    Raises
    ------
    ValueError
        ``f`` or ``gradient`` not callable, a bad bounding sphere, or a
        ``clip_box`` that is not a ``(2, 3)`` array of finite numbers with
        ``lo < hi`` on every axis, or that reaches outside the bounding
        sphere (the message names which).
    rdmesh.FeatureError
        (a ValueError) a feature polyline that is not an ``(m, 3)`` array of
        finite numbers, has fewer than two distinct points, or crosses
        another curve (or itself) away from the end points; the message names
        the polyline (``features[i]``).

    Notes
    -----
    Every call of ``f`` is checked: it must return ``N`` finite values.

    With a clip box, the sphere only has to contain the box: ``f`` need not
    be positive on it. The seeding grid spans the sphere
    (``seed_resolution`` cells across it), so a sphere just around the box
    (its circumscribed sphere, a little enlarged) wastes the fewest cells.
    ``VolumeSurface(border="clipped")`` sets the volume's box as its clip
    box. Nothing is certified for a clipped surface (the README, "Surfaces
    that leave the domain").

    Examples
    --------
    A gyroid lattice in a cube:

    >>> import rdmesh
    >>> gyroid = rdmesh.ImplicitSurface.from_expression(
    ...     "sin(x)*cos(y) + sin(y)*cos(z) + sin(z)*cos(x)",
    ...     ((0, 0, 0), 6.0),
    ...     clip_box=[(-3, -3, -3), (3, 3, 3)],
    ... )
    >>> mesh = rdmesh.mesh_surface(gyroid)  # doctest: +SKIP
    """

    f: ArrayFunction
    bounding_sphere: tuple
    gradient: ArrayFunction | None = None
    name: str = "implicit surface"
    clip_box: ArrayLike | None = None
    features: Any = None
    evaluations: int = field(default=0, init=False)

    def __post_init__(self) -> None:
        if not callable(self.f):
            raise ValueError("f must be callable on an (N, 3) array")
        if self.gradient is not None and not callable(self.gradient):
            raise ValueError("gradient must be callable or None")
        self.centre, self.radius = sphere(self.bounding_sphere)
        self._lock = threading.Lock()
        self.bounding_sphere = (self.centre, self.radius)
        if self.clip_box is not None:
            self.clip_box = box_in_sphere(self.clip_box, self.centre, self.radius, self.name)
        self.features = _features(self.features, self.radius)

    @classmethod
    def from_expression(
        cls,
        text: str,
        bounding_sphere: tuple,
        name: str | None = None,
        *,
        clip_box: ArrayLike | None = None,
        features: Any = None,
    ) -> ImplicitSurface:
        """The surface ``text = 0`` for an arithmetic expression in x, y and z.

        Parameters
        ----------
        text : str
            For example ``"x**2 + y**2 + z**2 - 1"``. Only numbers, ``x y z``,
            ``pi e tau``, ``+ - * / **`` and whitelisted math functions are
            accepted (see :mod:`rdmesh.surfaces.expressions`); it is never ``eval``-ed.
        bounding_sphere : (centre, radius)
            A sphere that strictly contains the surface (or the clip box).
        name : str, optional
            A label; the expression text by default.
        clip_box : (2, 3) array_like, optional
            Mesh only the part inside this axis-aligned box (lowest corner,
            highest corner), which must lie inside the bounding sphere; see
            :class:`ImplicitSurface`. The mesh then has a boundary on the
            box faces and nothing is certified for it.
        features : list of (m, 3) array_like, or "none", optional
            Feature curves to keep (see :class:`ImplicitSurface`).

        Returns
        -------
        ImplicitSurface
            Evaluated with numpy, with an exact gradient (forward-mode
            differentiation; central differences where it is not finite).

        Raises
        ------
        rdmesh.ExpressionError
            (a ValueError) naming what is not allowed, or a syntax error.
        ValueError
            A bad bounding sphere or clip box (see :class:`ImplicitSurface`).
        """
        from .expressions import parse_expression

        expr = parse_expression(text)
        centre, radius = sphere(bounding_sphere)
        step = GRADIENT_STEP * radius

        def gradient(points: np.ndarray) -> np.ndarray:
            return expr.gradient(points, step=step)

        return cls(
            expr, (centre, radius), gradient=gradient, name=name or expr.text, clip_box=clip_box,
            features=features,
        )  # fmt: skip

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Evaluate ``f`` on ``(N, 3)`` points; returns ``(N,)`` float64."""
        pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        n = len(pts)
        if n <= _CHUNK:
            return self._evaluate(pts)
        return np.concatenate([self._evaluate(pts[i : i + _CHUNK]) for i in range(0, n, _CHUNK)])

    def _evaluate(self, pts: np.ndarray) -> np.ndarray:
        n = len(pts)
        with self._lock:
            self.evaluations += n
        try:
            out = self.f(pts)
        except Exception as exc:  # noqa: BLE001 - user code may raise anything
            raise OracleError(f"the surface function raised {type(exc).__name__}: {exc}") from exc
        try:
            values = np.asarray(out, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise OracleError(f"the surface function returned non-numbers: {exc}") from exc
        if values.shape != (n,):
            raise OracleError(
                f"the surface function must return shape ({n},) for {n} points, got {values.shape}"
            )
        bad = ~np.isfinite(values)
        if bad.any():
            i = int(np.argmax(bad))
            raise OracleError(
                f"the surface function returned {values[i]} at {pts[i].tolist()} "
                f"({int(bad.sum())} non-finite values in {n})"
            )
        return values

    def grad(self, points: np.ndarray) -> np.ndarray:
        """Gradient of ``f`` at ``(N, 3)`` points, analytic or by finite differences."""
        pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        n = len(pts)
        if self.gradient is not None:
            with self._lock:
                self.evaluations += n
            try:
                g = np.asarray(self.gradient(pts), dtype=np.float64)
            except Exception as exc:  # noqa: BLE001
                raise OracleError(
                    f"the gradient function raised {type(exc).__name__}: {exc}"
                ) from exc
            if g.shape != (n, 3) or not np.all(np.isfinite(g)):
                raise OracleError(
                    f"the gradient function must return {n} finite rows of 3, got {g.shape}"
                )
            return g
        h = GRADIENT_STEP * self.radius
        steps = np.eye(3) * h
        probe = np.concatenate(
            [pts[None, :, :] + steps[:, None, :], pts[None, :, :] - steps[:, None, :]]
        )
        v = self(probe.reshape(-1, 3)).reshape(2, 3, n)
        return ((v[0] - v[1]) / (2 * h)).T


def _features(features: Any, radius: float) -> Any:
    """The checked ``features=``: "none", precomputed balls
    (:class:`~rdmesh.features.ProtectingBalls`, checked when made), or the
    polylines (an empty list for None or "auto"); the curves are built once
    here so that crossings are refused when the surface is made."""
    if features is None or (isinstance(features, str) and features == "auto"):
        return []
    from ..features.given import ProtectingBalls
    from ..features.graph import FeatureError, as_polylines, build_graph, given_curves

    if isinstance(features, ProtectingBalls):
        return features

    if isinstance(features, str):
        if features == "none":
            return "none"
        raise FeatureError(
            f"features must be a list of (m, 3) polylines, None or 'none', got {features!r}"
        )

    polylines = as_polylines(features)
    build_graph(given_curves(polylines, radius), radius)
    return polylines
