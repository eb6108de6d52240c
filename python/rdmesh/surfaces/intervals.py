"""Interval enclosures of expressions and of their gradients (algorithm.md, section 4.1).

:func:`interval` bounds an :class:`~rdmesh.surfaces.expressions.Expression`
over many axis-aligned boxes at once; :func:`interval_gradient` also bounds its
gradient, by forward-mode differentiation with interval components (interval
dual numbers), so nothing beyond the expression text is needed. The same
functions are the methods :meth:`Expression.interval` and
:meth:`Expression.interval_gradient`. A segment is handled through the box that
encloses it (or each piece of it).

Two evaluators apply the same rules. Expressions whose functions all have a
rule in the core (arithmetic, constant powers, ``sqrt``, ``exp``, ``log``,
``abs``, ``min``, ``max``, ``sin``, ``cos``: every built-in surface) run in
C++ (:mod:`~rdmesh.surfaces.interval_program`, ``cpp/interval_eval.cpp``),
box after box, several times faster; the others run here, in numpy. The
guarantees below hold for both.

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
  relative plus the smallest normal float: 8 to 16 ulps, where numpy's errors
  measured against 80-digit references stay below 3 ulps.
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

import math
from typing import NamedTuple

import numpy as np

from .expressions import (
    _NARY,
    _UNARY,
    Expression,
    _Const,
    _Nary,
    _Neg,
    _Node,
    _Pow,
    _Product,
    _Sum,
    _Unary,
    _Var,
    parse_expression,
)

__all__ = [
    "REL_WIDENING",
    "dot_bounds",
    "Enclosure",
    "GradientEnclosure",
    "interval",
    "interval_gradient",
]

#: Relative widening of results of functions that are not correctly rounded.
REL_WIDENING = 2.0**-49
_TINY = np.finfo(np.float64).tiny
_MAX = np.finfo(np.float64).max
_INF = np.inf
_PI_UP = float(np.nextafter(math.pi, _INF))  # above the true pi


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


# -- interval arithmetic on (lo, hi) array pairs ----------------------------------------
#
# Invariants: lo <= hi elementwise, lo < +inf, hi > -inf, no NaN. Arrays broadcast:
# values are (n,) or 0-d (constants), gradients (3, n) or (3, 1).


class _I:
    __slots__ = ("hi", "lo")

    def __init__(self, lo, hi) -> None:
        self.lo = lo
        self.hi = hi


# Outward rounding without np.nextafter (about 10 times slower): in round-to-nearest,
# fl(c - fl(fl(2**-52 * |c|) + 2**-1074)) <= the float below c, because 2**-52 * |c| is at
# least one ulp of c and the subnormal spacing is 2**-1074. One to two ulps outwards.
_ULP_REL = 2.0**-52
_ETA = 2.0**-1074


def _dn(x):
    """A float below x: +inf (an overflow) becomes the largest float, NaN becomes -inf."""
    e = np.minimum(np.abs(x), _MAX) * _ULP_REL + _ETA
    return np.fmax(np.minimum(x - e, _MAX), -_INF)


def _up(x):
    """A float above x: -inf becomes minus the largest float, NaN becomes +inf."""
    e = np.minimum(np.abs(x), _MAX) * _ULP_REL + _ETA
    return np.fmin(np.maximum(x + e, -_MAX), _INF)


def _dn_t(x):
    """Lower bound for a libm result: widened relatively and absolutely, then rounded."""
    return _dn(x - (np.minimum(np.abs(x), _MAX) * REL_WIDENING + _TINY))


def _up_t(x):
    return _up(x + (np.minimum(np.abs(x), _MAX) * REL_WIDENING + _TINY))


def _point(c) -> _I:
    c = np.asarray(c, dtype=np.float64)
    return _I(c, c)


def _const(c: float) -> _I:
    """An interval around a constant known only to within its rounding (e.g. ln 2)."""
    return _I(_dn(np.float64(c)), _up(np.float64(c)))


def _full(shape=()) -> _I:
    return _I(np.full(shape, -_INF), np.full(shape, _INF))


def _where(cond, a: _I, b: _I) -> _I:
    return _I(np.where(cond, a.lo, b.lo), np.where(cond, a.hi, b.hi))


def _clip(a: _I, lower=-_INF, upper=_INF) -> _I:
    """Intersect with a range that holds every true value (keeps exact bounds exact)."""
    return _I(np.clip(a.lo, lower, upper), np.clip(a.hi, lower, upper))


def _has0(a: _I):
    return (a.lo <= 0) & (a.hi >= 0)


def _sum_err(u, v):
    """fl(u + v) and its exact rounding error (Knuth's TwoSum; NaN error on overflow)."""
    s = u + v
    vv = s - u
    return s, (u - (s - vv)) + (v - vv)


def _add_dn(u, v):
    s, err = _sum_err(u, v)
    return np.where(err >= 0, s, _dn(s))  # exact sums (err == 0) are kept


def _add_up(u, v):
    s, err = _sum_err(u, v)
    return np.where(err <= 0, s, _up(s))


def _add(a: _I, b: _I) -> _I:
    return _I(_add_dn(a.lo, b.lo), _add_up(a.hi, b.hi))


def _sub(a: _I, b: _I) -> _I:
    return _I(_add_dn(a.lo, -b.hi), _add_up(a.hi, -b.lo))


def _neg(a: _I) -> _I:
    return _I(-a.hi, -a.lo)


def _pow2(u):
    """Where u is +-2**k (so that multiplying by it is exact unless it under/overflows)."""
    return np.abs(np.frexp(u)[0]) == 0.5


def _mul(a: _I, b: _I) -> _I:
    if a.lo is a.hi and b.lo is not b.hi:  # a point (a constant, a unit gradient): 2 corners
        a, b = b, a
    pairs = [(a.lo, b.lo), (a.hi, b.lo)]
    if b.lo is not b.hi:
        pairs += [(a.lo, b.hi), (a.hi, b.hi)]
    # Products by +-2**k (unit gradients, 2*x, sign) are exact in the normal range.
    two = {id(u): _pow2(u) for u in (a.lo, a.hi, b.lo, b.hi)}
    lo = hi = None
    for u, v in pairs:
        # A zero factor makes the product exactly 0, also against an infinite
        # bound (interval members are real; the bound is not one of them).
        zero = (u == 0) | (v == 0)
        p = np.where(zero, 0.0, u * v)
        exact = zero | ((two[id(u)] | two[id(v)]) & (np.abs(p) >= _TINY) & (np.abs(p) <= _MAX))
        plo = np.where(exact, p, _dn(p))
        phi = np.where(exact, p, _up(p))
        lo = plo if lo is None else np.minimum(lo, plo)
        hi = phi if hi is None else np.maximum(hi, phi)
    return _signed(_I(lo, hi), a, b)


def _signed(r: _I, a: _I, b: _I) -> _I:
    """Keep the sign of a*b or a/b when it is known (rounding an underflow to 0 can cross 0)."""
    nonneg = ((a.lo >= 0) & (b.lo >= 0)) | ((a.hi <= 0) & (b.hi <= 0))
    nonpos = ((a.lo >= 0) & (b.hi <= 0)) | ((a.hi <= 0) & (b.lo >= 0))
    return _I(
        np.where(nonneg, np.maximum(r.lo, 0.0), r.lo),
        np.where(nonpos, np.minimum(r.hi, 0.0), r.hi),
    )


def _recip(b: _I) -> _I:
    """1/b over the nonzero members of b (the extended reciprocal)."""
    # [l, h] with 0 < l or h < 0: [1/h, 1/l]; [0, h]: [1/h, inf]; [l, 0]: [-inf, 1/l];
    # l < 0 < h: [-inf, inf]. Signs are exact.
    off0 = (b.lo > 0) | (b.hi < 0)
    lo = np.where(off0 | (b.lo == 0), _dn(1.0 / b.hi), -_INF)
    hi = np.where(off0 | (b.hi == 0), _up(1.0 / b.lo), _INF)
    lo = np.where(b.lo >= 0, np.maximum(lo, 0.0), lo)
    hi = np.where(b.hi <= 0, np.minimum(hi, 0.0), hi)
    empty = (b.lo == 0) & (b.hi == 0)  # no nonzero member
    return _I(np.where(empty, -_INF, lo), np.where(empty, _INF, hi))


def _div(a: _I, b: _I) -> _I:
    """a/b over the nonzero members of b."""
    q1, q2 = a.lo / b.lo, a.lo / b.hi
    q3, q4 = a.hi / b.lo, a.hi / b.hi
    # inf/inf corners are NaN; the other corners already reach 0 and +-inf there.
    lo = np.fmin(np.fmin(q1, q2), np.fmin(q3, q4))
    hi = np.fmax(np.fmax(q1, q2), np.fmax(q3, q4))
    direct = _signed(_I(_dn(lo), _up(hi)), a, b)
    off0 = (b.lo > 0) | (b.hi < 0)
    if np.all(off0):
        return direct
    return _where(off0, direct, _mul(a, _recip(b)))


def _sqr(a: _I) -> _I:
    """The true square (one variable used twice): never below 0."""
    l2, h2 = a.lo * a.lo, a.hi * a.hi
    pos, neg = a.lo >= 0, a.hi <= 0
    lo = np.where(pos, l2, np.where(neg, h2, 0.0))
    hi = np.where(pos, h2, np.where(neg, l2, np.maximum(l2, h2)))
    return _I(np.maximum(_dn(lo), 0.0), _up(hi))


def _hull(a: _I, b: _I) -> _I:
    return _I(np.minimum(a.lo, b.lo), np.maximum(a.hi, b.hi))


def _mig(a: _I):
    """Least |x| over a."""
    return np.where(_has0(a), 0.0, np.minimum(np.abs(a.lo), np.abs(a.hi)))


def _mag(a: _I):
    """Largest |x| over a."""
    return np.maximum(np.abs(a.lo), np.abs(a.hi))


def _increasing(fn, a: _I) -> _I:
    return _I(_dn_t(fn(a.lo)), _up_t(fn(a.hi)))


def _decreasing(fn, a: _I) -> _I:
    return _I(_dn_t(fn(a.hi)), _up_t(fn(a.lo)))


def _keep_sign(r: _I, a: _I) -> _I:
    """For odd increasing r = f(a) with f(0) = 0: undo widening across 0."""
    return _I(
        np.where(a.lo >= 0, np.maximum(r.lo, 0.0), r.lo),
        np.where(a.hi <= 0, np.minimum(r.hi, 0.0), r.hi),
    )


def _restrict(a: _I, lower=None, upper=None, open_lower=False, open_upper=False):
    """Clip a to a function's domain.

    Returns (clipped, undefined, empty): undefined where a leaves the domain,
    empty where no member of a is in it.
    """
    undef = np.zeros(np.broadcast(a.lo, a.hi).shape, dtype=bool)
    empty = undef.copy()
    lo, hi = a.lo, a.hi
    if lower is not None:
        undef = undef | ((lo <= lower) if open_lower else (lo < lower))
        empty = empty | ((hi <= lower) if open_lower else (hi < lower))
        lo = np.maximum(lo, lower)
    if upper is not None:
        undef = undef | ((hi >= upper) if open_upper else (hi > upper))
        empty = empty | ((lo >= upper) if open_upper else (lo > upper))
        hi = np.minimum(hi, upper)
    empty = empty | (lo > hi)
    return _I(lo, np.maximum(lo, hi)), undef, empty


def _blank(r: _I, empty) -> _I:
    """[-inf, inf] where the argument had no member in the domain."""
    if not np.any(empty):
        return r
    return _I(np.where(empty, -_INF, r.lo), np.where(empty, _INF, r.hi))


def _hits(a: _I, phase: float, period: float):
    """Where a may contain phase + k*period for an integer k (errs towards True)."""
    tl = (a.lo - phase) / period
    th = (a.hi - phase) / period
    return np.floor(th + 1e-12 * (1.0 + np.abs(th))) >= np.ceil(tl - 1e-12 * (1.0 + np.abs(tl)))


def _sin(a: _I) -> _I:
    return _wave(np.sin, a, math.pi / 2, -math.pi / 2)


def _cos(a: _I) -> _I:
    return _wave(np.cos, a, 0.0, math.pi)


def _wave(fn, a: _I, top: float, bottom: float) -> _I:
    """sin or cos: endpoint values, and +-1 where a maximum or minimum lies inside."""
    f1, f2 = fn(a.lo), fn(a.hi)  # NaN at infinite ends; those rows hit both extrema
    lo = np.where(_hits(a, bottom, 2 * math.pi), -1.0, _dn_t(np.minimum(f1, f2)))
    hi = np.where(_hits(a, top, 2 * math.pi), 1.0, _up_t(np.maximum(f1, f2)))
    return _clip(_I(lo, hi), -1.0, 1.0)


def _pow_int(a: _I, n: float) -> _I:
    """a**n for an integer n >= 1."""
    if n == 1:
        return a
    if n == 2:
        return _sqr(a)
    lo_n, hi_n = np.power(a.lo, n), np.power(a.hi, n)
    if math.fmod(n, 2.0) == 1.0:  # odd: increasing
        return _keep_sign(_I(_dn_t(lo_n), _up_t(hi_n)), a)
    pos, neg = a.lo >= 0, a.hi <= 0
    lo = np.where(pos, lo_n, np.where(neg, hi_n, 0.0))
    hi = np.where(pos, hi_n, np.where(neg, lo_n, np.maximum(lo_n, hi_n)))
    return _I(np.maximum(_dn_t(lo), 0.0), _up_t(hi))


def _pow_const(a: _I, c: float):
    """a**c for a constant float c: (interval, undefined)."""
    no = np.zeros(np.shape(a.lo), dtype=bool)
    if c == 0:
        return _point(1.0), no  # numpy: x**0 == 1 for every x
    if not math.isfinite(c):
        return _full(np.shape(a.lo)), ~no
    if c == math.floor(c):
        if c > 0:
            return _pow_int(a, c), no
        return _recip(_pow_int(a, -c)), _has0(a)
    # A non-integer power needs a base >= 0 (> 0 when c < 0).
    b, undef, empty = _restrict(a, 0.0, open_lower=c < 0)
    r = (_increasing if c > 0 else _decreasing)(lambda u: np.power(u, c), b)
    return _blank(_I(np.maximum(r.lo, 0.0), r.hi), empty), undef


def _log(a: _I) -> _I:
    return _increasing(np.log, a)


def _exp(a: _I) -> _I:
    r = _increasing(np.exp, a)
    return _I(np.maximum(r.lo, 0.0), r.hi)


# -- unary functions: name -> (value, derivative, domain) --------------------------------
#
# value(a) and derivative(a, value) take the argument clipped to the domain, which is
# (lower, upper, open_lower, open_upper) or None. The derivative formulas retrace
# expressions._UNARY (1/sqrt(1 - u*u) for asin, ...), so that an enclosure on a point
# box also holds numpy's rounded derivative there (the tests rely on it).


def _ln_const(base: float) -> _I:
    return _const(math.log(base))


def _tan(a: _I):
    pole = _hits(a, math.pi / 2, math.pi)
    return _where(pole, _full(), _increasing(np.tan, a)), pole


def _d_abs(a: _I, _v: _I) -> _I:
    """sign(u), and the hull [-1, 1] of both branches where 0 is in a."""
    return _I(np.where(a.lo > 0, 1.0, -1.0), np.where(a.hi < 0, -1.0, 1.0))


def _steps(jump):
    """Derivative of a non-decreasing step function: 0, or [0, inf] across a jump."""

    def d(a: _I, _v: _I) -> _I:
        j = jump(a)
        return _I(np.zeros(np.shape(j)), np.where(j, _INF, 0.0))

    return d


def _sqrt(a: _I) -> _I:
    # IEEE 754 square roots are correctly rounded: no libm widening needed.
    return _I(np.maximum(_dn(np.sqrt(a.lo)), 0.0), _up(np.sqrt(a.hi)))


def _cosh(a: _I) -> _I:
    r = _I(_dn_t(np.cosh(_mig(a))), _up_t(np.cosh(_mag(a))))
    return _I(np.maximum(r.lo, 1.0), r.hi)


def _through0(fn, lower=-_INF, upper=_INF):
    """An increasing function with fn(0) = 0, whose range lies in [lower, upper]."""
    return lambda a: _clip(_keep_sign(_increasing(fn, a), a), lower, upper)


_ONE = _point(1.0)
_HALF = _point(0.5)
_THREE = _point(3.0)

_UNARY_IV = {
    "sin": (_sin, lambda a, v: _cos(a), None),
    "cos": (_cos, lambda a, v: _neg(_sin(a)), None),
    # tan is handled apart (poles); its derivative is 1/cos(u)**2.
    "asin": (
        _through0(np.arcsin),
        lambda a, v: _recip(_sqrt(_clip(_sub(_ONE, _sqr(a)), 0.0))),
        (-1.0, 1.0, False, False),
    ),
    "acos": (
        lambda a: _clip(_decreasing(np.arccos, a), 0.0),
        lambda a, v: _neg(_recip(_sqrt(_clip(_sub(_ONE, _sqr(a)), 0.0)))),
        (-1.0, 1.0, False, False),
    ),
    "atan": (_through0(np.arctan), lambda a, v: _recip(_add(_ONE, _sqr(a))), None),
    "sinh": (_through0(np.sinh), lambda a, v: _cosh(a), None),
    "cosh": (_cosh, lambda a, v: _through0(np.sinh)(a), None),
    "tanh": (
        _through0(np.tanh, -1.0, 1.0),
        lambda a, v: _clip(_sub(_ONE, _sqr(v)), 0.0, 1.0),
        None,
    ),
    "asinh": (_through0(np.arcsinh), lambda a, v: _recip(_sqrt(_add(_sqr(a), _ONE))), None),
    "acosh": (
        lambda a: _clip(_increasing(np.arccosh, a), 0.0),
        lambda a, v: _recip(_sqrt(_clip(_sub(_sqr(a), _ONE), 0.0))),
        (1.0, None, False, False),
    ),
    "atanh": (
        _through0(np.arctanh),
        lambda a, v: _recip(_clip(_sub(_ONE, _sqr(a)), 0.0)),
        (-1.0, 1.0, True, True),
    ),
    "exp": (_exp, lambda a, v: v, None),
    "expm1": (lambda a: _clip(_through0(np.expm1)(a), -1.0), lambda a, v: _exp(a), None),
    "log": (_log, lambda a, v: _recip(a), (0.0, None, True, False)),
    "log1p": (
        lambda a: _keep_sign(_increasing(np.log1p, a), a),
        lambda a, v: _recip(_add(_ONE, a)),
        (-1.0, None, True, False),
    ),
    "log2": (
        lambda a: _increasing(np.log2, a),
        lambda a, v: _recip(_mul(a, _ln_const(2.0))),
        (0.0, None, True, False),
    ),
    "log10": (
        lambda a: _increasing(np.log10, a),
        lambda a, v: _recip(_mul(a, _ln_const(10.0))),
        (0.0, None, True, False),
    ),
    "sqrt": (_sqrt, lambda a, v: _mul(_HALF, _recip(v)), (0.0, None, False, False)),
    "cbrt": (_through0(np.cbrt), lambda a, v: _recip(_mul(_THREE, _sqr(v))), None),
    "abs": (
        lambda a: _I(_mig(a), _mag(a)),
        _d_abs,
        None,
    ),
    "sign": (
        lambda a: _I(np.sign(a.lo), np.sign(a.hi)),
        _steps(_has0),
        None,
    ),
    "floor": (
        lambda a: _I(np.floor(a.lo), np.floor(a.hi)),
        _steps(lambda a: np.ceil(a.lo) <= a.hi),
        None,
    ),
    "ceil": (
        lambda a: _I(np.ceil(a.lo), np.ceil(a.hi)),
        _steps(lambda a: np.ceil(a.lo) <= a.hi),
        None,
    ),
}


# -- the tree walk -----------------------------------------------------------------------


def _is_constant(node: _Node) -> bool:
    """True when the sub-tree uses no variable."""
    if isinstance(node, _Const):
        return True
    if isinstance(node, _Var):
        return False
    if isinstance(node, (_Neg, _Unary)):
        return _is_constant(node.a)
    if isinstance(node, (_Sum, _Product)):
        return all(
            _is_constant(n) for n, _ in (node.terms if isinstance(node, _Sum) else node.factors)
        )
    if isinstance(node, _Pow):
        return _is_constant(node.a) and _is_constant(node.b)
    return all(_is_constant(n) for n in node.args)


class _Walker:
    """Evaluates a tree on boxes as interval duals: (value, gradient or None)."""

    def __init__(self, lo: np.ndarray, hi: np.ndarray, gradient: bool) -> None:
        n = len(lo)
        self.xyz = [_I(lo[:, k], hi[:, k]) for k in range(3)]
        self.gradient = gradient
        self.undefined = np.zeros(n, dtype=bool)
        self._unit = [_point(np.eye(3)[k][:, None]) for k in range(3)]

    def flag(self, mask) -> None:
        self.undefined = self.undefined | mask

    def walk(self, node: _Node):
        if isinstance(node, _Const):
            c = node.c
            if not math.isfinite(c):  # e.g. 1e999: not a real number
                self.flag(True)
                return _I(_dn(c), _up(c)), None
            return _point(c), None
        if isinstance(node, _Var):
            return self.xyz[node.i], (self._unit[node.i] if self.gradient else None)
        if isinstance(node, _Neg):
            v, g = self.walk(node.a)
            return _neg(v), None if g is None else _neg(g)
        if isinstance(node, _Sum):
            return self.sum(node)
        if isinstance(node, _Product):
            return self.product(node)
        if isinstance(node, _Pow):
            return self.power(node.a, node.b)
        if isinstance(node, _Unary):
            return self.unary(node)
        if isinstance(node, _Nary):
            return self.nary(node)
        raise TypeError(f"no interval rule for {type(node).__name__}")  # pragma: no cover

    def sum(self, node: _Sum):
        total, grad = None, None
        for term, minus in node.terms:
            v, g = self.walk(term)
            if minus:
                v, g = _neg(v), (None if g is None else _neg(g))
            total = v if total is None else _add(total, v)
            grad = g if grad is None else (grad if g is None else _add(grad, g))
        return total, grad

    def product(self, node: _Product):
        out, grad = self.walk(node.factors[0][0])
        for factor, divide in node.factors[1:]:
            v, g = self.walk(factor)
            if divide:
                self.flag(_has0(v))
                out = _div(out, v)
                # d(u/v) = (du - (u/v) dv) * (1/v), as the point dual computes it.
                if g is not None:
                    dv = _mul(g, out)
                    grad = _neg(dv) if grad is None else _sub(grad, dv)
                if grad is not None:
                    grad = _mul(grad, _recip(v))
            else:
                if grad is not None:
                    grad = _mul(grad, v)
                if g is not None:
                    gu = _mul(g, out)
                    grad = gu if grad is None else _add(grad, gu)
                out = _mul(out, v)
        return out, grad

    def power(self, base: _Node, exponent: _Node):
        a, ga = self.walk(base)
        if _is_constant(exponent):
            with np.errstate(all="ignore"):
                c = float(exponent.value(None))
            v, undef = _pow_const(a, c)
            self.flag(undef)
            if ga is None or c == 0:
                return v, None
            if not math.isfinite(c):
                return v, _full(np.shape(ga.lo))
            dv, _ = _pow_const(a, c - 1.0)
            return v, _mul(ga, _mul(_point(c), dv))
        b, gb = self.walk(exponent)
        # a**b = exp(b*log(a)) for a > 0.
        ac, undef, empty = _restrict(a, 0.0, open_lower=True)
        self.flag(undef)
        la = _log(ac)
        v = _blank(_exp(_mul(b, la)), empty)
        grad = None
        if ga is not None:
            d = _mul(b, _exp(_mul(_sub(b, _ONE), la)))
            grad = _mul(ga, _blank(d, empty))
        if gb is not None:
            gl = _mul(gb, _blank(_mul(v, la), empty))
            grad = gl if grad is None else _add(grad, gl)
        return v, grad

    def unary(self, node: _Unary):
        a, ga = self.walk(node.a)
        name = node.name
        if name == "tan":
            v, pole = _tan(a)
            self.flag(pole)
            if ga is None:
                return v, None
            return v, _mul(ga, _recip(_sqr(_cos(a))))
        value, deriv, domain = _UNARY_IV[name]
        empty = None
        if domain is not None:
            lower, upper, open_lower, open_upper = domain
            a, undef, empty = _restrict(a, lower, upper, open_lower, open_upper)
            self.flag(undef)
        v = value(a)
        if empty is not None:
            v = _blank(v, empty)
        if ga is None:
            return v, None
        d = deriv(a, v)
        if empty is not None:
            d = _blank(d, empty)
        return v, _mul(ga, d)

    def nary(self, node: _Nary):
        name = node.name
        if name == "pow":
            return self.power(node.args[0], node.args[1])
        duals = [self.walk(n) for n in node.args]
        if name == "atan2":
            return self.atan2(*duals[0], *duals[1])
        if name == "hypot":
            return self.hypot(duals)
        return self.minmax(duals, name == "min")

    def atan2(self, y: _I, gy, x: _I, gx):
        origin = _has0(x) & _has0(y)
        self.flag(origin)
        # Off the origin and the branch cut (y = 0, x < 0) the angle of a box is
        # continuous, and its extremes are at corners.
        jump = origin | ((x.lo < 0) & _has0(y))
        c = [np.arctan2(yy, xx) for yy in (y.lo, y.hi) for xx in (x.lo, x.hi)]
        lo = _dn_t(np.minimum(np.minimum(c[0], c[1]), np.minimum(c[2], c[3])))
        hi = _up_t(np.maximum(np.maximum(c[0], c[1]), np.maximum(c[2], c[3])))
        v = _clip(_I(np.where(jump, -_PI_UP, lo), np.where(jump, _PI_UP, hi)), -_PI_UP, _PI_UP)
        if gy is None and gx is None:
            return v, None
        r2 = _add(_sqr(x), _sqr(y))
        grad = None
        if gy is not None:
            grad = _mul(gy, _div(x, r2))
        if gx is not None:
            t = _mul(gx, _neg(_div(y, r2)))
            grad = t if grad is None else _add(grad, t)
        return v, _where(jump, _full(), grad)

    def hypot(self, duals):
        lo, hi = _mig(duals[0][0]), _mag(duals[0][0])
        for a, _ in duals[1:]:
            lo = np.maximum(_dn_t(np.hypot(lo, _mig(a))), 0.0)
            hi = _up_t(np.hypot(hi, _mag(a)))
        out = _I(lo, hi)
        grad = None
        for a, g in duals:
            if g is not None:
                t = _mul(g, _clip(_div(a, out), -1.0, 1.0))
                grad = t if grad is None else _add(grad, t)
        return out, grad

    def minmax(self, duals, is_min: bool):
        out, grad = duals[0]
        for v, g in duals[1:]:
            if is_min:
                only_out, only_v = out.hi < v.lo, v.hi < out.lo
                out = _I(np.minimum(out.lo, v.lo), np.minimum(out.hi, v.hi))
            else:
                only_out, only_v = out.lo > v.hi, v.lo > out.hi
                out = _I(np.maximum(out.lo, v.lo), np.maximum(out.hi, v.hi))
            if grad is None and g is None:
                continue
            zero = _point(0.0)
            ga = zero if grad is None else grad
            gb = zero if g is None else g
            # Where both branches can be taken, the hull of both gradients.
            grad = _where(only_out, ga, _where(only_v, gb, _hull(ga, gb)))
        return out, grad


# -- public entry points -------------------------------------------------------------------


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
    if (lo == _INF).any() or (hi == -_INF).any():
        raise ValueError("lo must be below +inf and hi above -inf")
    return np.ascontiguousarray(lo), np.ascontiguousarray(hi)


def _as_expression(expr: Expression | str) -> Expression:
    return parse_expression(expr) if isinstance(expr, str) else expr


#: Run expressions through the core's evaluator when it has a rule for every
#: function in them (the tests switch it off to check the numpy path too).
NATIVE = True


def native_program(expr: Expression):
    """The expression's program for the core's evaluator, ``(ops, consts)``, or None
    (the evaluator is switched off, or the expression uses a function it lacks)."""
    if not NATIVE:
        return None
    if not expr._program:
        from .interval_program import compile_program

        expr._program.append(compile_program(expr._root))
    return expr._program[0]


def _bounds(expr: Expression, lo, hi, gradient: bool, mean_value: bool):
    """(flo, fhi, glo, ghi, undefined); glo and ghi are None without gradient."""
    program = native_program(expr)
    if program is not None:
        from ..core import evaluate_intervals

        flo, fhi, glo, ghi, undefined = evaluate_intervals(
            program[0], program[1], lo, hi, gradient, mean_value
        )
        return flo, fhi, glo, ghi, undefined.view(bool)
    flo, fhi, glo, ghi, undefined = _evaluate(expr, lo, hi, gradient or mean_value)
    if mean_value:
        flo, fhi = _mean_value(expr, lo, hi, flo, fhi, glo, ghi, undefined)
    return flo, fhi, glo, ghi, undefined


def _evaluate(expr: Expression, lo, hi, gradient: bool):
    n = len(lo)
    walker = _Walker(lo, hi, gradient)
    with np.errstate(all="ignore"):
        v, g = walker.walk(expr._root)
    flo = np.array(np.broadcast_to(v.lo, (n,)), dtype=np.float64)
    fhi = np.array(np.broadcast_to(v.hi, (n,)), dtype=np.float64)
    undefined = np.array(np.broadcast_to(walker.undefined, (n,)))
    if not gradient:
        return flo, fhi, None, None, undefined
    if g is None:
        glo = ghi = np.zeros((n, 3))
    else:
        glo = np.array(np.broadcast_to(g.lo, (3, n)).T, dtype=np.float64)
        ghi = np.array(np.broadcast_to(g.hi, (3, n)).T, dtype=np.float64)
    return flo, fhi, glo, ghi, undefined


def _mean_value(expr: Expression, lo, hi, flo, fhi, glo, ghi, undefined):
    """Intersect with f(m) + G(X).(X - m), m the box centre, where f is defined."""
    ok = ~undefined & np.isfinite(lo).all(axis=1) & np.isfinite(hi).all(axis=1)
    ok &= np.isfinite(glo).all(axis=1) & np.isfinite(ghi).all(axis=1)
    if not ok.any():
        return flo, fhi
    m = np.where(ok[:, None], np.clip(0.5 * lo + 0.5 * hi, lo, hi), 0.0)
    mlo, mhi, _, _, mundef = _evaluate(expr, m, m, gradient=False)
    ok &= ~mundef
    with np.errstate(all="ignore"):
        total = _I(mlo, mhi)
        for k in range(3):
            dk = _sub(_I(lo[:, k], hi[:, k]), _point(m[:, k]))
            total = _add(total, _mul(_I(glo[:, k], ghi[:, k]), dk))
    out_lo = np.where(ok, np.maximum(flo, total.lo), flo)
    out_hi = np.where(ok, np.minimum(fhi, total.hi), fhi)
    return out_lo, out_hi


def dot_bounds(glo: np.ndarray, ghi: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Outward-rounded bounds of ``G . d`` for gradient boxes ``G`` and vectors ``d``.

    Components with ``d == 0`` add nothing; non-finite bounds elsewhere give
    an unbounded result.
    """
    with np.errstate(invalid="ignore"):  # inf * 0 where d == 0: replaced below
        p1, p2 = glo * d, ghi * d
    zero = d == 0
    lo = np.where(zero, 0.0, np.minimum(p1, p2))
    hi = np.where(zero, 0.0, np.maximum(p1, p2))
    bad = ~(np.isfinite(lo) & np.isfinite(hi)).all(axis=1)
    s_lo, s_hi = lo.sum(axis=1), hi.sum(axis=1)
    # Three products and two sums: a few ulps of the magnitudes.
    slack = 8 * np.finfo(np.float64).eps * np.maximum(np.abs(lo), np.abs(hi)).sum(axis=1) + _TINY
    s_lo = np.where(bad, -np.inf, s_lo - slack)
    s_hi = np.where(bad, np.inf, s_hi + slack)
    return s_lo, s_hi


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
    expr = _as_expression(expr)
    lo, hi = _boxes(lo, hi)
    flo, fhi, _, _, undefined = _bounds(expr, lo, hi, False, mean_value)
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
    expr = _as_expression(expr)
    lo, hi = _boxes(lo, hi)
    flo, fhi, glo, ghi, undefined = _bounds(expr, lo, hi, True, mean_value)
    return GradientEnclosure(flo, fhi, glo, ghi, undefined)


# Every function of the grammar has a rule here (checked on import, so a function
# added to the compiler without one fails loudly instead of silently).
_MISSING = (set(_UNARY) - set(_UNARY_IV) - {"tan"}) | (
    set(_NARY) - {"min", "max", "hypot", "atan2", "pow"}
)
if _MISSING:  # pragma: no cover
    raise ImportError(f"no interval rule for {sorted(_MISSING)}")
