"""The equations of creases and corners for tracing (:mod:`rdmesh.creases.tracing`).

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
    """The equations of creases. Crease ``c`` separates two pieces: every
    decision node held on ``forced[c]`` (side A), and the same with the
    nodes of ``delta[c]`` on their other branch (side B: those nodes switch
    together across the crease). Its equations are side A's piece ``F`` and
    the switch ``s`` of ``node[c]``, the first node of ``delta[c]``. A
    point's event is the first node outside ``delta[c]`` that reaches ``f``
    (on either side) and would take another branch there (-1 for none).

    Parameters
    ----------
    model : PieceModel
    forced : (C, D) int8 each crease's side-A branches (-1: free).
    node : (C,) int64 each crease's switching node.
    delta : (C, D) bool the nodes that switch across each crease.
    """

    def __init__(
        self, model: PieceModel, forced: np.ndarray, node: np.ndarray, delta: np.ndarray
    ) -> None:
        self.model = model
        self.forced = np.asarray(forced, np.int8).reshape(-1, model.size)
        self.node = np.asarray(node, np.int64)
        self.delta = np.asarray(delta, bool).reshape(-1, model.size)

    def __call__(self, x: np.ndarray, curve: np.ndarray):
        r = self.model.evaluate(x, self.forced[curve])
        k = self.node[curve]
        rows = np.arange(len(x))
        g = np.column_stack([r.value, r.switch[rows, k]])
        J = np.stack([r.grad, r.switch_grad[rows, k]], axis=1)
        return g, J, self.event(r, curve)

    def event(self, r, curve: np.ndarray) -> np.ndarray:
        """The first node outside the crease's switching nodes that reaches
        ``f`` (on either side of the crease) and takes another branch on its
        own, or -1; ``r`` is the model's evaluation with side A forced."""
        n, d = r.choice.shape
        delta = self.delta[curve]
        reach = np.ones((n, d), bool)
        for j, path in enumerate(self.model.above):
            for m, branch in path:
                reach[:, j] &= (r.choice[:, m] == branch) | delta[:, m]
        flip = reach & (r.natural != r.choice) & ~delta
        return np.where(flip.any(axis=1), np.argmax(flip, axis=1), -1)

    def sides(self, curve: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The branches of side A and of side B of each crease, ``(m, D)`` each."""
        a = self.forced[curve]
        return a, np.where(self.delta[curve], 1 - a, a).astype(np.int8)

    def pieces_angle(self, x: np.ndarray, curve: np.ndarray) -> np.ndarray:
        """The angle in degrees between the two pieces' gradients at points on
        curves: near 0 for a smooth join, near 180 where two sheets touch, in
        between for a crease (its sharpness)."""
        a, b = (self.model.evaluate(x, side).grad for side in self.sides(curve))
        sine = row_norms(np.cross(a, b))
        cosine = np.einsum("ij,ij->i", a, b)
        return np.degrees(np.arctan2(sine, cosine))

    def corner_system(self, x: np.ndarray, curve: np.ndarray, other: np.ndarray):
        """Residuals ``(m, 3)`` and Jacobians ``(m, 3, 3)`` of the piece and
        both switches (the crease's node and ``other``)."""
        r, k = self.model.evaluate(x, self.forced[curve]), self.node[curve]
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
