"""Interval enclosures of expressions and of their gradients (algorithm.md, section 4.1).

:func:`interval` bounds an :class:`~rdmesh.surfaces.expressions.Expression`
over many axis-aligned boxes at once; :func:`interval_gradient` also bounds its
gradient, by forward-mode differentiation with interval components (interval
dual numbers), so nothing beyond the expression text is needed. The same
functions are the methods :meth:`Expression.interval` and
:meth:`Expression.interval_gradient`. A segment is handled through the box that
encloses it (or each piece of it).

The expression is compiled once into a straight-line program
(:mod:`~rdmesh.surfaces.interval_program`) that the core runs box after box
(``cpp/interval_eval.cpp``), with a rule for every function of the grammar.
The tests hold it against a numpy evaluator of the same rules
(``tests/interval_reference.py``) and against sampled and exact values.

What is guaranteed
------------------
For box ``i`` and every point ``p`` of it where ``f`` is defined,
``lo[i] <= f(p) <= hi[i]``; where ``f`` is also differentiable,
``glo[i] <= grad f(p) <= ghi[i]``. "Defined" means that every sub-expression
has a finite real value at ``p``. ``f`` is the exact real function that the
text describes, with each number and named constant taken as its float64 value
(``pi`` is the double nearest to pi) and a constant exponent of ``**`` or
``pow`` taken as the float64 that point evaluation computes (so ``x**(4/2)``
is ``x**2``).

- Outward rounding after every operation: a bound that may have been rounded
  is moved one to two ulps outwards (at least as far as :func:`numpy.nextafter`
  would, at a tenth of its cost). Results known to be exact are kept: sums
  whose rounding error (Knuth's TwoSum) is 0, and products by 0 or by a power
  of 2. Results of functions that are not correctly rounded (``sin``,
  ``exp``, ``pow``, ``cbrt``, ...) are first widened by :data:`REL_WIDENING`
  relative plus the smallest normal float: 8 to 16 ulps, where the C
  library's errors, measured against 80-digit references in the tests, stay
  below 3 ulps.
- Bounds may be infinite (overflow, a pole, ``sqrt`` at 0 in a gradient),
  never NaN. A bound that is mathematically exact and representable is kept
  (``x**2 >= 0``, ``|sin| <= 1``, ``cosh >= 1``).
- ``undefined[i]`` is True when box ``i`` may contain points where ``f`` is
  not defined: outside the domain of ``sqrt``, ``log``, ``asin``, ``acosh``,
  ``atanh``, ...; at a pole (division by an interval containing 0, ``tan``,
  ``log(0)``, a negative power of 0, ``atan2(0, 0)``); a negative base under
  a non-integer or variable exponent; an infinite constant. It is
  conservative (it may be True for a box where ``f`` is defined everywhere,
  e.g. ``sqrt(x - x)``) but never False for a box holding such a point. The
  bounds of such a box still enclose ``f`` on the points where it is defined,
  so ``0 not in [lo, hi]`` still proves that the box holds no point of the
  surface; when no point of the box is defined they are ``[-inf, inf]``.
- Non-smooth functions get a gradient enclosure ``G`` that keeps the
  mean-value inclusion ``f(q) - f(p) in G . (q - p)`` for all points ``p, q``
  of a box not flagged undefined, so monotonicity and root-counting arguments
  stay valid:
  ``abs``, ``min``, ``max`` and ``hypot`` at their kinks give the convex hull
  of the one-sided derivatives (the Clarke gradient), never the active branch
  alone; a jump of ``sign``, ``floor``, ``ceil`` or of ``atan2`` across its
  branch cut inside a box makes that factor unbounded (``[0, inf]`` for the
  non-decreasing steps).

What it is not: tight. Each occurrence of a variable is treated
independently (``x*x`` on ``[-1, 2]`` is ``[-2, 4]``, while ``x**2`` is
``[0, 4]``), so bounds overestimate, more so on large boxes. The mean-value
form (``mean_value=True``) narrows them on small boxes.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from .. import core
from ._parse import parse
from .interval_program import compile_program
from .ir import Node

if TYPE_CHECKING:
    from .expressions import Expression

__all__ = [
    "REL_WIDENING",
    "Enclosure",
    "GradientEnclosure",
    "interval",
    "interval_gradient",
    "program_of",
]

#: Relative widening of results of functions that are not correctly rounded.
REL_WIDENING: float = core.INTERVAL_REL_WIDENING


class Enclosure(NamedTuple):
    """Bounds of ``f`` over ``n`` boxes.

    Attributes
    ----------
    lo, hi : (n,) float64 arrays
        ``lo <= f(p) <= hi`` for every point ``p`` of the box where ``f`` is
        defined. May be infinite, never NaN.
    undefined : (n,) bool array
        The box may contain points where ``f`` is not defined (a conservative
        flag: never False for a box holding such a point).
    """

    lo: np.ndarray
    hi: np.ndarray
    undefined: np.ndarray


class GradientEnclosure(NamedTuple):
    """Bounds of ``f`` and of its gradient over ``n`` boxes.

    Attributes
    ----------
    lo, hi : (n,) float64 arrays
        Bounds of ``f``, as in :class:`Enclosure`.
    glo, ghi : (n, 3) float64 arrays
        ``glo <= grad f(p) <= ghi`` for every point ``p`` of the box where
        ``f`` is defined and differentiable; at kinks they hold the convex hull
        of the one-sided derivatives. May be infinite, never NaN.
    undefined : (n,) bool array
        As in :class:`Enclosure`.
    """

    lo: np.ndarray
    hi: np.ndarray
    glo: np.ndarray
    ghi: np.ndarray
    undefined: np.ndarray


def program_of(expr: Expression) -> tuple[np.ndarray, np.ndarray]:
    """The expression's program for the core's evaluator, ``(ops, consts)``
    (compiled on first use and kept with the expression)."""
    if not expr._program:
        expr._program.append(compile_program(expr._root))
    return expr._program[0]


def _bounds(root: Node, program, lo, hi, gradient: bool, mean_value: bool):
    """(flo, fhi, glo, ghi, undefined) of the tree ``root`` compiled to
    ``program``; glo and ghi are None without gradient. (The tests put the
    numpy reference evaluator in its place.)"""
    flo, fhi, glo, ghi, undefined = core.evaluate_intervals(
        program[0], program[1], lo, hi, gradient, mean_value
    )
    return flo, fhi, glo, ghi, undefined.view(bool)


def _source(expr: Expression | str):
    """The tree and the program of an expression or of its text."""
    if isinstance(expr, str):
        root = parse(expr)[1]
        return root, compile_program(root)
    return expr._root, program_of(expr)


def _boxes(lo, hi) -> tuple[np.ndarray, np.ndarray]:
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    if lo.shape == (3,):
        lo = lo[None]
    if hi.shape == (3,):
        hi = hi[None]
    if lo.ndim != 2 or lo.shape[1] != 3 or lo.shape != hi.shape:
        raise ValueError(f"lo and hi must both have shape (n, 3); got {lo.shape} and {hi.shape}")
    if np.isnan(lo).any() or np.isnan(hi).any():
        raise ValueError("box bounds must not be NaN")
    if (lo > hi).any():
        raise ValueError("every box needs lo <= hi")
    if (lo == np.inf).any() or (hi == -np.inf).any():
        raise ValueError("lo must be below +inf and hi above -inf")
    return np.ascontiguousarray(lo), np.ascontiguousarray(hi)


def interval(
    expr: Expression | str, lo: np.ndarray, hi: np.ndarray, *, mean_value: bool = False
) -> Enclosure:
    """Bound an expression over axis-aligned boxes.

    Parameters
    ----------
    expr : Expression or str
        The expression, or its text (parsed with
        :func:`~rdmesh.surfaces.expressions.parse_expression`).
    lo, hi : (n, 3) array_like
        Lower and upper corners of ``n`` boxes (a single box may be given as
        ``(3,)``); ``lo <= hi``; infinite bounds are allowed, NaN is not.
    mean_value : bool, optional
        Also use the mean-value form ``f(m) + G(X).(X - m)`` (``m`` the box
        centre, ``G`` the gradient enclosure) and keep the intersection with
        the natural enclosure: never looser, and much tighter on small boxes.
        It costs a gradient evaluation. Applied only where ``f`` is defined on
        the whole box.

    Returns
    -------
    Enclosure
        ``(lo, hi, undefined)``, each ``(n,)``: see the module docstring for
        what is guaranteed.

    Raises
    ------
    ValueError
        For boxes of the wrong shape, with NaN bounds or with ``lo > hi``.

    Examples
    --------
    >>> r = interval("x**2", [-1.0, 0, 0], [2.0, 0, 0])
    >>> r.lo, r.hi - 4.0, r.undefined
    (array([0.]), array([8.8817842e-16]), array([False]))
    """
    root, program = _source(expr)
    lo, hi = _boxes(lo, hi)
    flo, fhi, _, _, undefined = _bounds(root, program, lo, hi, False, mean_value)
    return Enclosure(flo, fhi, undefined)


def interval_gradient(
    expr: Expression | str, lo: np.ndarray, hi: np.ndarray, *, mean_value: bool = False
) -> GradientEnclosure:
    """Bound an expression and its gradient over axis-aligned boxes.

    The gradient comes from forward-mode differentiation with interval
    components, in the same pass as the value.

    Parameters
    ----------
    expr : Expression or str
        The expression, or its text.
    lo, hi : (n, 3) array_like
        Lower and upper corners of ``n`` boxes, as in :func:`interval`.
    mean_value : bool, optional
        Tighten the bounds of ``f`` (not of the gradient) by the mean-value
        form, as in :func:`interval`.

    Returns
    -------
    GradientEnclosure
        ``(lo, hi, glo, ghi, undefined)``: ``(n,)`` bounds of ``f``, ``(n, 3)``
        bounds of its gradient, and the ``(n,)`` undefined flags.

    Raises
    ------
    ValueError
        For boxes of the wrong shape, with NaN bounds or with ``lo > hi``.
    """
    root, program = _source(expr)
    lo, hi = _boxes(lo, hi)
    flo, fhi, glo, ghi, undefined = _bounds(root, program, lo, hi, True, mean_value)
    return GradientEnclosure(flo, fhi, glo, ghi, undefined)
