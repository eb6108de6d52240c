"""Safe arithmetic expressions in x, y and z, vectorised with numpy.

:func:`parse_expression` turns text such as ``"x**2 + y**2 + z**2 - 1"`` into
an :class:`Expression`: a function of ``(N, 3)`` points with an exact
gradient. The text is parsed with Python's :mod:`ast` module and checked
against a whitelist; it is never passed to ``eval``. Accepted:

- numbers (integers and decimals, e.g. ``2``, ``0.5``, ``1e-3``);
- the variables ``x``, ``y``, ``z`` and the constants ``pi``, ``e``, ``tau``;
- ``+``, ``-``, ``*``, ``/``, ``**`` and unary ``-`` and ``+``; parentheses;
- calls of the functions in :data:`FUNCTIONS` (``sin``, ``cos``, ``exp``,
  ``sqrt``, ``abs``, ``min``, ``max``, ...), with positional arguments.

Anything else (attribute access, subscripts, other names or calls, keyword
arguments, comparisons, strings, lambdas, ...) raises
:class:`ExpressionError` naming the construct and its column.

Arithmetic is IEEE float64 throughout, constants included, so ``1/0`` is
``inf`` and ``9**9**9`` is ``inf``: neither raises nor takes long. Non-finite
values are reported by :class:`~rdmesh.ImplicitSurface` when meshing.

The gradient is computed exactly by forward-mode differentiation over the
syntax tree (one pass, no symbolic blow-up; :mod:`rdmesh.surfaces.pointwise`).
``abs``, ``min`` and ``max`` use the derivative of the active branch (``abs``
has derivative 0 at 0). Where the exact derivative is not finite (``sqrt`` at
0, say), those rows fall back to central differences.

:meth:`Expression.interval` and :meth:`Expression.interval_gradient` bound the
value and the gradient over boxes, with outward rounding
(:mod:`rdmesh.surfaces.intervals`).

The parsed tree lives in :mod:`rdmesh.surfaces.ir`, which every evaluator
reads; the parser is :mod:`rdmesh.surfaces._parse`.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .._errors import ExpressionError
from . import intervals, pointwise
from ._parse import MAX_DEPTH, MAX_LENGTH, parse
from .ir import CONSTANTS, FUNCTIONS, VARIABLES, Node
from .pieces import PieceModel

__all__ = [
    "CONSTANTS",
    "FUNCTIONS",
    "MAX_DEPTH",
    "MAX_LENGTH",
    "VARIABLES",
    "Expression",
    "ExpressionError",
    "parse_expression",
]


#: Guards every expression's box count (the facet worker thread bounds boxes too).
_BOX_COUNT_LOCK = threading.Lock()


@dataclass(frozen=True, eq=False)
class Expression:
    """A parsed expression: ``expr(points)`` evaluates it on ``(N, 3)`` points.

    Use :func:`parse_expression` to make one.

    Attributes
    ----------
    text : str
        The expression as given (stripped of surrounding blanks).
    variables : frozenset of str
        Which of ``x``, ``y``, ``z`` occur.
    """

    text: str
    variables: frozenset
    _root: Node
    # Boxes bounded so far (a mutable cell: the dataclass is frozen).
    _boxes: list = field(default_factory=lambda: [0], repr=False)
    # The core's interval program, compiled on first use (a mutable cell).
    _program: list = field(default_factory=list, repr=False)

    @cached_property
    def pieces(self) -> PieceModel:
        """The expression's ``min``, ``max`` and ``abs`` branches and its
        smooth pieces (:class:`~rdmesh.surfaces.pieces.PieceModel`)."""
        return PieceModel(self._root)

    @property
    def interval_evaluations(self) -> int:
        """Boxes (or segments, or points) bounded by interval arithmetic so far."""
        return self._boxes[0]

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Values at ``(N, 3)`` points, ``(N,)`` float64 (NaN/inf where undefined)."""
        xyz, n = _columns(points)
        with np.errstate(all="ignore"):
            v = pointwise.value(self._root, xyz)
        return np.array(np.broadcast_to(np.asarray(v, dtype=np.float64), (n,)))

    def gradient(self, points: np.ndarray, step: float = 1e-6) -> np.ndarray:
        """Exact gradient at ``(N, 3)`` points, ``(N, 3)`` float64.

        Rows where the exact derivative is not finite (e.g. ``sqrt`` at 0) are
        replaced by central differences with the given ``step``.
        """
        xyz, n = _columns(points)
        with np.errstate(all="ignore"):
            _, g = pointwise.dual(self._root, xyz)
            out = (
                np.zeros((n, 3))
                if g is None
                else np.array(np.broadcast_to(np.asarray(g, dtype=np.float64), (3, n)).T)
            )
            bad = ~np.isfinite(out).all(axis=1)
            if bad.any():
                p = np.column_stack(xyz)[bad]
                h = np.eye(3) * step
                for k in range(3):
                    out[bad, k] = (self(p + h[k]) - self(p - h[k])) / (2.0 * step)
        return out

    def interval(
        self, lo: np.ndarray, hi: np.ndarray, *, mean_value: bool = False
    ) -> intervals.Enclosure:
        """Bounds of the expression over ``(n, 3)`` boxes ``[lo, hi]``.

        Returns an :class:`~rdmesh.surfaces.intervals.Enclosure`
        ``(lo, hi, undefined)`` of ``(n,)`` arrays, rounded outwards; see
        :func:`rdmesh.surfaces.intervals.interval`.
        """
        out = intervals.interval(self, lo, hi, mean_value=mean_value)
        self.count_boxes(len(out.lo))
        return out

    def interval_gradient(
        self, lo: np.ndarray, hi: np.ndarray, *, mean_value: bool = False
    ) -> intervals.GradientEnclosure:
        """Bounds of the expression and of its gradient over ``(n, 3)`` boxes.

        Returns a :class:`~rdmesh.surfaces.intervals.GradientEnclosure`
        ``(lo, hi, glo, ghi, undefined)``; see
        :func:`rdmesh.surfaces.intervals.interval_gradient`.
        """
        out = intervals.interval_gradient(self, lo, hi, mean_value=mean_value)
        self.count_boxes(len(out.lo))
        return out

    def count_boxes(self, n: int) -> None:
        """Add ``n`` boxes bounded elsewhere (the core's proofs) to
        :attr:`interval_evaluations`; safe from several threads."""
        with _BOX_COUNT_LOCK:
            self._boxes[0] += n

    def __repr__(self) -> str:
        return f"Expression({self.text!r})"


def _columns(points) -> tuple[tuple, int]:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        p = p.reshape(-1, 3)
    return (p[:, 0], p[:, 1], p[:, 2]), len(p)


def parse_expression(text: str) -> Expression:
    """Parse an arithmetic expression in ``x``, ``y`` and ``z``.

    Parameters
    ----------
    text : str
        For example ``"x**2 + y**2 + z**2 - 1"`` or
        ``"sin(x)*cos(y) + sin(y)*cos(z) + sin(z)*cos(x)"``.

    Returns
    -------
    Expression

    Raises
    ------
    ExpressionError
        (a ValueError) for syntax errors, names and functions not in the
        whitelist, any other Python construct, text longer than
        :data:`MAX_LENGTH` or nesting deeper than :data:`MAX_DEPTH`.
    """
    text, root, variables = parse(text)
    return Expression(text, variables, root)
