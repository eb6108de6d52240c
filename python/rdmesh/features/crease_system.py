"""The equations of creases and corners for tracing (:mod:`rdmesh.features.tracing`).

A crease of a piecewise smooth function (:class:`~rdmesh.surfaces.pieces.PieceModel`)
is ``{F = 0, s = 0}``: the piece ``F`` (every decision node held on a branch,
the switching node on its first) and that node's switch ``s``. A corner on it
is where another node switches too: ``{F = 0, s = 0, s' = 0}``.
"""

from __future__ import annotations

import numpy as np

from .._vectors import row_norms
from ..surfaces.pieces import PieceModel
from .tracing import newton_project


class CreaseSystem:
    """The equations of creases: for curve ``c``, the piece ``F`` (every node
    held on ``forced[c]``, node ``node[c]`` on its first branch) and that
    node's switch; a point's event is the first other node that reaches
    ``f`` and would take another branch there (-1 for none).

    Parameters
    ----------
    model : PieceModel
    forced : (C, D) int8 the branches of each curve's piece (-1: free).
    node : (C,) int64 each curve's switching node.
    """

    def __init__(self, model: PieceModel, forced: np.ndarray, node: np.ndarray) -> None:
        self.model = model
        self.forced = np.asarray(forced, np.int8).reshape(-1, model.size)
        self.node = np.asarray(node, np.int64)

    def __call__(self, x: np.ndarray, curve: np.ndarray):
        r, k = self._evaluate(x, curve)
        rows = np.arange(len(x))
        g = np.column_stack([r.value, r.switch[rows, k]])
        J = np.stack([r.grad, r.switch_grad[rows, k]], axis=1)
        return g, J, self._event(r, k)

    def _evaluate(self, x: np.ndarray, curve: np.ndarray):
        k = self.node[curve]
        forced = self.forced[curve].copy()
        forced[np.arange(len(x)), k] = 0
        return self.model.evaluate(x, forced), k

    def _event(self, r, k: np.ndarray) -> np.ndarray:
        """The first node other than ``k`` that reaches ``f`` (with either
        branch of ``k``) and takes another branch on its own, or -1."""
        n, d = r.choice.shape
        reach = np.ones((n, d), bool)
        for j, path in enumerate(self.model.above):
            for m, branch in path:
                reach[:, j] &= (r.choice[:, m] == branch) | (k == m)
        flip = reach & (r.natural != r.choice)
        flip[np.arange(n), k] = False
        return np.where(flip.any(axis=1), np.argmax(flip, axis=1), -1)

    def pieces_sine(self, x: np.ndarray, curve: np.ndarray) -> np.ndarray:
        """The sine of the angle between the two pieces' gradients at points
        on curves (the crease's sharpness; 0 for a smooth join)."""
        k = self.node[curve]
        rows = np.arange(len(x))
        grads = []
        for branch in (0, 1):
            forced = self.forced[curve].copy()
            forced[rows, k] = branch
            grads.append(self.model.evaluate(x, forced).grad)
        a, b = grads
        cross = row_norms(np.cross(a, b))
        return cross / np.maximum(row_norms(a) * row_norms(b), 1e-300)

    def corner_system(self, x: np.ndarray, curve: np.ndarray, other: np.ndarray):
        """Residuals ``(m, 3)`` and Jacobians ``(m, 3, 3)`` of the piece and
        both switches (the crease's node and ``other``)."""
        r, k = self._evaluate(x, curve)
        rows = np.arange(len(x))
        g = np.column_stack([r.value, r.switch[rows, k], r.switch[rows, other]])
        J = np.stack([r.grad, r.switch_grad[rows, k], r.switch_grad[rows, other]], axis=1)
        return g, J


def solve_corner(
    system: CreaseSystem, a: np.ndarray, b: np.ndarray, crease: int, other: int, tol: float
) -> np.ndarray:
    """Where node ``other`` switches on crease ``crease`` between the points
    ``a`` (before) and ``b`` (after) of a trace: Newton on the three
    equations from ``b`` (each scaled by its gradient), accepted within two
    steps of ``b``; bisection along the curve when Newton fails."""
    c = np.array([crease])
    x = b[None].copy()
    for _ in range(30):
        g, J = system.corner_system(x, c, np.array([other]))
        n = np.linalg.norm(J, axis=2)
        if not np.all(np.isfinite(J)) or np.any(n == 0):
            break
        Js, gs = J / n[:, :, None], g / n
        try:
            step = -np.linalg.solve(Js[0], gs[0])
        except np.linalg.LinAlgError:
            break
        x = x + step
        if np.abs(gs).max() <= tol and np.linalg.norm(step) <= tol:
            if np.linalg.norm(x[0] - b) <= 2.0 * float(np.linalg.norm(b - a)) + tol:
                return x[0]
            break
    return _bisect(system, a, b, c, tol)


def _bisect(system: CreaseSystem, a: np.ndarray, b: np.ndarray, c: np.ndarray, tol: float):
    """The last point of the curve before the event between ``a`` and ``b``."""
    for _ in range(60):
        mid, _, _ = newton_project(system, 0.5 * (a + b)[None], c, tol)
        _, _, ev = system(mid, c)
        if ev[0] >= 0:
            b = mid[0]
        else:
            a = mid[0]
        if np.linalg.norm(b - a) <= tol:
            break
    return a


class Projection:
    """Points near crease ``c`` of ``system`` onto it (minimum-norm
    Gauss-Newton to the residual ``tol``): a :class:`FeatureCurve`'s
    ``project``."""

    def __init__(self, system: CreaseSystem, c: int, tol: float) -> None:
        self.system, self.c, self.tol = system, c, tol

    def __call__(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64).reshape(-1, 3)
        y, _, _ = newton_project(self.system, x, np.full(len(x), self.c), self.tol, 20)
        return y
