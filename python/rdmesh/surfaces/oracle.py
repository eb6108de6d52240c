"""Surface oracles: a vectorised implicit function plus its bounding sphere."""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .._errors import OracleError
from .._tol import GRADIENT_STEP
from .._validate import sphere

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
        and outside it.
    gradient : callable, optional
        Maps ``(N, 3)`` points to ``(N, 3)`` gradients of ``f``. Without it,
        central finite differences are used.
    name : str, optional
        A label for logs and reports.

    Notes
    -----
    Every call of ``f`` is checked: it must return ``N`` finite values.
    ``evaluations`` counts the points evaluated so far. ``clip_box`` (None
    here) is set by surfaces meshed only inside an axis-aligned box within
    the sphere, such as ``VolumeSurface(border="clipped")``: a ``(2, 3)``
    array of the lowest and highest corners; they need
    ``topology="manifold-with-boundary"``.
    """

    f: ArrayFunction
    bounding_sphere: tuple
    gradient: ArrayFunction | None = None
    name: str = "implicit surface"
    evaluations: int = field(default=0, init=False)

    def __post_init__(self) -> None:
        if not callable(self.f):
            raise ValueError("f must be callable on an (N, 3) array")
        if self.gradient is not None and not callable(self.gradient):
            raise ValueError("gradient must be callable or None")
        self.centre, self.radius = sphere(self.bounding_sphere)
        self._lock = threading.Lock()
        self.bounding_sphere = (self.centre, self.radius)
        #: The box the mesh is clipped to (None: the bounding ball only).
        self.clip_box: np.ndarray | None = None

    @classmethod
    def from_expression(
        cls, text: str, bounding_sphere: tuple, name: str | None = None
    ) -> ImplicitSurface:
        """The surface ``text = 0`` for an arithmetic expression in x, y and z.

        Parameters
        ----------
        text : str
            For example ``"x**2 + y**2 + z**2 - 1"``. Only numbers, ``x y z``,
            ``pi e tau``, ``+ - * / **`` and whitelisted math functions are
            accepted (see :mod:`rdmesh.surfaces.expressions`); it is never ``eval``-ed.
        bounding_sphere : (centre, radius)
            A sphere that strictly contains the surface.
        name : str, optional
            A label; the expression text by default.

        Returns
        -------
        ImplicitSurface
            Evaluated with numpy, with an exact gradient (forward-mode
            differentiation; central differences where it is not finite).

        Raises
        ------
        rdmesh.ExpressionError
            (a ValueError) naming what is not allowed, or a syntax error.
        """
        from .expressions import parse_expression

        expr = parse_expression(text)
        centre, radius = sphere(bounding_sphere)
        step = GRADIENT_STEP * radius

        def gradient(points: np.ndarray) -> np.ndarray:
            return expr.gradient(points, step=step)

        return cls(expr, (centre, radius), gradient=gradient, name=name or expr.text)

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
