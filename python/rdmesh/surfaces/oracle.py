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
        ``certify=True`` raise ValueError). Default None: no box, only the ball.
    features : list of (m, 3) array_like, "auto", "none" or ProtectingBalls, optional
        Feature curves to keep in the mesh (creases, sharp edges), each a
        polyline of points on the surface in order along the curve (a last
        point repeating the first closes it). Curves may meet only at their
        end points (the corners); an end point on another curve's interior
        splits it there. The mesh has a vertex at every corner and its edges
        follow each curve (protecting balls: :mod:`rdmesh.features`). Curves
        the domain makes (a ``clip_box`` or the sphere cutting the surface,
        a closed volume's box, a mesh's sharp edges) are protected as well.
        Default None (or "auto"): those, and the creases and corners found
        where ``min``, ``max`` and ``abs`` switch in an expression or a
        :mod:`rdmesh.csg` shape; "none": nothing (creases are chamfered); a
        :class:`rdmesh.features.ProtectingBalls`: those balls alone.

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
        another curve (or itself) away from its end points (the message names
        ``features[i]``); or ``sign``, ``floor`` or ``ceil`` in ``f`` (auto).

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
        self.centre, self.radius, self.clip_box, self.features = _checked_fields(self)
        self.bounding_sphere, self._lock = (self.centre, self.radius), threading.Lock()

    @classmethod
    def from_expression(
        cls, text: str, bounding_sphere: tuple, name: str | None = None, *,
        clip_box: ArrayLike | None = None, features: Any = None,
    ) -> ImplicitSurface:  # fmt: skip
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
        features : list of (m, 3) array_like, "auto" or "none", optional
            Default "auto": the creases found in the expression (see above).

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
        return _from_expression(cls, text, bounding_sphere, name, clip_box, features)

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Evaluate ``f`` on ``(N, 3)`` points; returns ``(N,)`` float64."""
        return _evaluate_in_chunks(self, points)

    def grad(self, points: np.ndarray) -> np.ndarray:
        """Gradient of ``f`` at ``(N, 3)`` points, analytic or by finite differences."""
        return _evaluate_gradient(self, points, 2)


def _checked_fields(
    surface: ImplicitSurface,
) -> tuple[np.ndarray, float, np.ndarray | None, list[np.ndarray] | str]:
    """The checked fields of a new ``surface``: the bounding sphere's centre and
    radius, the clip box (a copy, or None) and the features (see :func:`_features`).

    Raises
    ------
    ValueError
        ``f`` or ``gradient`` not callable, a bad bounding sphere or clip box.
    rdmesh.FeatureError
        Bad feature curves.
    """
    if not callable(surface.f):
        raise ValueError("f must be callable on an (N, 3) array")
    if surface.gradient is not None and not callable(surface.gradient):
        raise ValueError("gradient must be callable or None")
    centre, radius = sphere(surface.bounding_sphere)
    box = surface.clip_box
    if box is not None:
        box = box_in_sphere(box, centre, radius, surface.name)
    return centre, radius, box, _features(surface.features, radius, surface.f, surface.name)


def _from_expression(
    cls: type[ImplicitSurface], text: str, bounding_sphere: tuple, name: str | None,
    clip_box: ArrayLike | None, features: Any,
) -> ImplicitSurface:  # fmt: skip
    """:meth:`ImplicitSurface.from_expression`: ``cls`` made with the parsed
    expression as ``f``, its forward-mode gradient, and the expression text as the
    default name."""
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


def _evaluate_in_chunks(surface: ImplicitSurface, points: np.ndarray) -> np.ndarray:
    """``surface(points)``: ``f`` on ``(N, 3)`` points, at most ``_CHUNK`` at a time."""
    pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    n = len(pts)
    if n <= _CHUNK:
        return _evaluate(surface, pts)
    return np.concatenate([_evaluate(surface, pts[i : i + _CHUNK]) for i in range(0, n, _CHUNK)])


def _read_only(pts: np.ndarray) -> np.ndarray:
    """A read-only view of ``pts`` for the user's functions: one that wrote
    into its argument would move rdmesh's own points."""
    view = pts.view()
    view.flags.writeable = False
    return view


def _evaluate(surface: ImplicitSurface, pts: np.ndarray) -> np.ndarray:
    """``surface.f`` on C-contiguous ``(n, 3)`` points, counted and checked: ``(n,)``.

    Raises
    ------
    rdmesh.OracleError
        ``f`` raised, or did not return ``n`` finite numbers.
    """
    n = len(pts)
    with surface._lock:
        surface.evaluations += n
    try:
        out = surface.f(_read_only(pts))
    except Exception as exc:  # noqa: BLE001 - user code may raise anything
        raise OracleError(f"the surface function raised {type(exc).__name__}: {exc}") from exc
    if np.iscomplexobj(out):
        raise OracleError("the surface function returned complex numbers; f must be real")
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


def forward_gradient(surface: ImplicitSurface, points: np.ndarray) -> np.ndarray:
    """``surface.grad(points)`` where a direction is all that is needed: without
    a gradient function, forward differences of ``f`` (four evaluations per
    point, ``f`` at the point included, against six for central ones), with a
    relative error about ``1e-6 R`` times the curvature; ``(N, 3)``."""
    return _evaluate_gradient(surface, points, 1)


def _evaluate_gradient(surface: ImplicitSurface, points: np.ndarray, order: int) -> np.ndarray:
    """``surface.grad(points)``: the given gradient, counted and checked, or
    central (``order`` 2) or forward (1) differences of ``f`` with step
    ``GRADIENT_STEP * radius``; ``(N, 3)``.

    Raises
    ------
    rdmesh.OracleError
        The gradient function raised, or did not return ``N`` finite rows of 3.
    """
    pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    n = len(pts)
    if surface.gradient is not None:
        with surface._lock:
            surface.evaluations += n
        try:
            g = np.asarray(surface.gradient(_read_only(pts)), dtype=np.float64)
        except Exception as exc:  # noqa: BLE001
            raise OracleError(f"the gradient function raised {type(exc).__name__}: {exc}") from exc
        if g.shape != (n, 3) or not np.all(np.isfinite(g)):
            raise OracleError(
                f"the gradient function must return {n} finite rows of 3, got {g.shape}"
            )
        return g
    h = GRADIENT_STEP * surface.radius
    steps = np.eye(3) * h
    if order == 1:
        probe = np.concatenate([pts[None, :, :], pts[None, :, :] + steps[:, None, :]])
        v = surface(probe.reshape(-1, 3)).reshape(4, n)
        return ((v[1:] - v[0]) / h).T
    probe = np.concatenate(
        [pts[None, :, :] + steps[:, None, :], pts[None, :, :] - steps[:, None, :]]
    )
    v = surface(probe.reshape(-1, 3)).reshape(2, 3, n)
    return ((v[0] - v[1]) / (2 * h)).T


def _features(features: Any, radius: float, f: Any, name: str) -> Any:
    """The checked ``features=``: "none", precomputed balls
    (:class:`~rdmesh.features.ProtectingBalls`, checked when made), or the
    polylines (an empty list for None or "auto": curves found, or none
    given); the curves are built once
    here so that crossings are refused when the surface is made, and so are
    step functions where creases are to be found."""
    from ..features.given import ProtectingBalls
    from ..features.graph import FeatureError, as_polylines, build_graph, given_curves

    if isinstance(features, ProtectingBalls):
        return features
    if features is None or (isinstance(features, str) and features == "auto"):
        from .expressions import Expression
        from .pieces import PiecewiseFunction

        model = f.pieces if isinstance(f, Expression) else getattr(f, "model", None)
        steps = model.steps() if isinstance(f, (Expression, PiecewiseFunction)) else []
        if steps:
            raise FeatureError(
                f"{name!r} uses {', '.join(steps)}: its surface jumps there, while creases are "
                "found only where min, max and abs switch; pass features='none' to mesh it "
                "without looking for creases"
            )
        return []

    if isinstance(features, str):
        if features == "none":
            return "none"
        raise FeatureError(
            "features must be a list of (m, 3) polylines, 'auto', None or 'none', got "
            f"{features!r}"
        )

    polylines = as_polylines(features)
    build_graph(given_curves(polylines, radius), radius)
    return polylines
