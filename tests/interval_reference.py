"""The numpy reference of the core's interval evaluator and of what runs on it.

The library has one implementation of interval evaluation, box subdivision
and root isolation: the core's (``cpp/interval_eval.cpp``,
``cpp/box_proofs.cpp``, ``cpp/segment_roots.cpp``). This module applies the
same rules in numpy, vectorised over all boxes of a level, so that the tests
can compare the two (``test_intervals.py``, ``test_interval_core.py``):

- :func:`bounds` stands in for :func:`rdmesh.surfaces.intervals._bounds`
  (the tests patch it in): a tree walk with interval duals, rule for rule
  as the core's ``Machine`` (same domains, undefined flags, Clarke hulls,
  libm widening and outward rounding; the two differ by a few ulps where
  numpy's and the C library's functions round differently).
- :func:`isolate_roots` is ``rdmesh.sampling.isolate.isolate_roots`` with the
  bisection level by level instead of the core's depth first.
- :func:`subdivide` is ``rdmesh.topology.proven_cells._subdivide`` (the
  core's ``prove_boxes``) level by level.
- :func:`dot_bounds` is the core's ``gradient_keeps_sign``, as bounds.
"""

from __future__ import annotations

import math

import numpy as np
from rdmesh.core import boxes_outside_cells
from rdmesh.sampling.isolate import _isolation
from rdmesh.surfaces.ir import (
    Const,
    Nary,
    Neg,
    Node,
    Pow,
    Product,
    Sum,
    Unary,
    Var,
    is_constant,
)
from rdmesh.surfaces.pointwise import value as point_value

#: Relative widening of results of functions that are not correctly rounded.
REL_WIDENING = 2.0**-49

_TINY = np.finfo(np.float64).tiny
_MAX = np.finfo(np.float64).max
_INF = np.inf
_PI_UP = float(np.nextafter(math.pi, _INF))  # above the true pi


# -- interval arithmetic on (lo, hi) array pairs ----------------------------------------
#
# Invariants: lo <= hi elementwise, lo < +inf, hi > -inf, no NaN. Arrays broadcast:
# values are (n,) or 0-d (constants), gradients (3, n) or (3, 1).


class Iv:
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


def _point(c) -> Iv:
    c = np.asarray(c, dtype=np.float64)
    return Iv(c, c)


def _const(c: float) -> Iv:
    """An interval around a constant known only to within its rounding (e.g. ln 2)."""
    return Iv(_dn(np.float64(c)), _up(np.float64(c)))


def _full(shape=()) -> Iv:
    return Iv(np.full(shape, -_INF), np.full(shape, _INF))


def _where(cond, a: Iv, b: Iv) -> Iv:
    return Iv(np.where(cond, a.lo, b.lo), np.where(cond, a.hi, b.hi))


def _clip(a: Iv, lower=-_INF, upper=_INF) -> Iv:
    """Intersect with a range that holds every true value (keeps exact bounds exact)."""
    return Iv(np.clip(a.lo, lower, upper), np.clip(a.hi, lower, upper))


def _has0(a: Iv):
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


def _add(a: Iv, b: Iv) -> Iv:
    return Iv(_add_dn(a.lo, b.lo), _add_up(a.hi, b.hi))


def _sub(a: Iv, b: Iv) -> Iv:
    return Iv(_add_dn(a.lo, -b.hi), _add_up(a.hi, -b.lo))


def _neg(a: Iv) -> Iv:
    return Iv(-a.hi, -a.lo)


def _pow2(u):
    """Where u is +-2**k (so that multiplying by it is exact unless it under/overflows)."""
    return np.abs(np.frexp(u)[0]) == 0.5


def _mul(a: Iv, b: Iv) -> Iv:
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
    return _signed(Iv(lo, hi), a, b)


def _signed(r: Iv, a: Iv, b: Iv) -> Iv:
    """Keep the sign of a*b or a/b when it is known (rounding an underflow to 0 can cross 0)."""
    nonneg = ((a.lo >= 0) & (b.lo >= 0)) | ((a.hi <= 0) & (b.hi <= 0))
    nonpos = ((a.lo >= 0) & (b.hi <= 0)) | ((a.hi <= 0) & (b.lo >= 0))
    return Iv(
        np.where(nonneg, np.maximum(r.lo, 0.0), r.lo),
        np.where(nonpos, np.minimum(r.hi, 0.0), r.hi),
    )


def _recip(b: Iv) -> Iv:
    """1/b over the nonzero members of b (the extended reciprocal)."""
    # [l, h] with 0 < l or h < 0: [1/h, 1/l]; [0, h]: [1/h, inf]; [l, 0]: [-inf, 1/l];
    # l < 0 < h: [-inf, inf]. Signs are exact.
    off0 = (b.lo > 0) | (b.hi < 0)
    lo = np.where(off0 | (b.lo == 0), _dn(1.0 / b.hi), -_INF)
    hi = np.where(off0 | (b.hi == 0), _up(1.0 / b.lo), _INF)
    lo = np.where(b.lo >= 0, np.maximum(lo, 0.0), lo)
    hi = np.where(b.hi <= 0, np.minimum(hi, 0.0), hi)
    empty = (b.lo == 0) & (b.hi == 0)  # no nonzero member
    return Iv(np.where(empty, -_INF, lo), np.where(empty, _INF, hi))


def _div(a: Iv, b: Iv) -> Iv:
    """a/b over the nonzero members of b."""
    q1, q2 = a.lo / b.lo, a.lo / b.hi
    q3, q4 = a.hi / b.lo, a.hi / b.hi
    # inf/inf corners are NaN; the other corners already reach 0 and +-inf there.
    lo = np.fmin(np.fmin(q1, q2), np.fmin(q3, q4))
    hi = np.fmax(np.fmax(q1, q2), np.fmax(q3, q4))
    direct = _signed(Iv(_dn(lo), _up(hi)), a, b)
    off0 = (b.lo > 0) | (b.hi < 0)
    if np.all(off0):
        return direct
    return _where(off0, direct, _mul(a, _recip(b)))


def _sqr(a: Iv) -> Iv:
    """The true square (one variable used twice): never below 0."""
    l2, h2 = a.lo * a.lo, a.hi * a.hi
    pos, neg = a.lo >= 0, a.hi <= 0
    lo = np.where(pos, l2, np.where(neg, h2, 0.0))
    hi = np.where(pos, h2, np.where(neg, l2, np.maximum(l2, h2)))
    return Iv(np.maximum(_dn(lo), 0.0), _up(hi))


def _hull(a: Iv, b: Iv) -> Iv:
    return Iv(np.minimum(a.lo, b.lo), np.maximum(a.hi, b.hi))


def _mig(a: Iv):
    """Least |x| over a."""
    return np.where(_has0(a), 0.0, np.minimum(np.abs(a.lo), np.abs(a.hi)))


def _mag(a: Iv):
    """Largest |x| over a."""
    return np.maximum(np.abs(a.lo), np.abs(a.hi))


def _increasing(fn, a: Iv) -> Iv:
    return Iv(_dn_t(fn(a.lo)), _up_t(fn(a.hi)))


def _decreasing(fn, a: Iv) -> Iv:
    return Iv(_dn_t(fn(a.hi)), _up_t(fn(a.lo)))


def _keep_sign(r: Iv, a: Iv) -> Iv:
    """For odd increasing r = f(a) with f(0) = 0: undo widening across 0."""
    return Iv(
        np.where(a.lo >= 0, np.maximum(r.lo, 0.0), r.lo),
        np.where(a.hi <= 0, np.minimum(r.hi, 0.0), r.hi),
    )


def _restrict(a: Iv, lower=None, upper=None, open_lower=False, open_upper=False):
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
    return Iv(lo, np.maximum(lo, hi)), undef, empty


def _blank(r: Iv, empty) -> Iv:
    """[-inf, inf] where the argument had no member in the domain."""
    if not np.any(empty):
        return r
    return Iv(np.where(empty, -_INF, r.lo), np.where(empty, _INF, r.hi))


def _hits(a: Iv, phase: float, period: float):
    """Where a may contain phase + k*period for an integer k (errs towards True)."""
    tl = (a.lo - phase) / period
    th = (a.hi - phase) / period
    return np.floor(th + 1e-12 * (1.0 + np.abs(th))) >= np.ceil(tl - 1e-12 * (1.0 + np.abs(tl)))


def _sin(a: Iv) -> Iv:
    return _wave(np.sin, a, math.pi / 2, -math.pi / 2)


def _cos(a: Iv) -> Iv:
    return _wave(np.cos, a, 0.0, math.pi)


def _wave(fn, a: Iv, top: float, bottom: float) -> Iv:
    """sin or cos: endpoint values, and +-1 where a maximum or minimum lies inside."""
    f1, f2 = fn(a.lo), fn(a.hi)  # NaN at infinite ends; those rows hit both extrema
    lo = np.where(_hits(a, bottom, 2 * math.pi), -1.0, _dn_t(np.minimum(f1, f2)))
    hi = np.where(_hits(a, top, 2 * math.pi), 1.0, _up_t(np.maximum(f1, f2)))
    return _clip(Iv(lo, hi), -1.0, 1.0)


def _pow_int(a: Iv, n: float) -> Iv:
    """a**n for an integer n >= 1."""
    if n == 1:
        return a
    if n == 2:
        return _sqr(a)
    lo_n, hi_n = np.power(a.lo, n), np.power(a.hi, n)
    if math.fmod(n, 2.0) == 1.0:  # odd: increasing
        return _keep_sign(Iv(_dn_t(lo_n), _up_t(hi_n)), a)
    pos, neg = a.lo >= 0, a.hi <= 0
    lo = np.where(pos, lo_n, np.where(neg, hi_n, 0.0))
    hi = np.where(pos, hi_n, np.where(neg, lo_n, np.maximum(lo_n, hi_n)))
    return Iv(np.maximum(_dn_t(lo), 0.0), _up_t(hi))


def _pow_const(a: Iv, c: float):
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
    return _blank(Iv(np.maximum(r.lo, 0.0), r.hi), empty), undef


def _log(a: Iv) -> Iv:
    return _increasing(np.log, a)


def _exp(a: Iv) -> Iv:
    r = _increasing(np.exp, a)
    return Iv(np.maximum(r.lo, 0.0), r.hi)


# -- unary functions: name -> (value, derivative, domain) --------------------------------
#
# value(a) and derivative(a, value) take the argument clipped to the domain, which is
# (lower, upper, open_lower, open_upper) or None. The derivative formulas retrace
# rdmesh.surfaces.pointwise (1/sqrt(1 - u*u) for asin, ...), so that an enclosure on a
# point box also holds numpy's rounded derivative there (the tests rely on it).


def _ln_const(base: float) -> Iv:
    return _const(math.log(base))


def _tan(a: Iv):
    pole = _hits(a, math.pi / 2, math.pi)
    return _where(pole, _full(), _increasing(np.tan, a)), pole


def _d_abs(a: Iv, _v: Iv) -> Iv:
    """sign(u), and the hull [-1, 1] of both branches where 0 is in a."""
    return Iv(np.where(a.lo > 0, 1.0, -1.0), np.where(a.hi < 0, -1.0, 1.0))


def _steps(jump):
    """Derivative of a non-decreasing step function: 0, or [0, inf] across a jump."""

    def d(a: Iv, _v: Iv) -> Iv:
        j = jump(a)
        return Iv(np.zeros(np.shape(j)), np.where(j, _INF, 0.0))

    return d


def _sqrt(a: Iv) -> Iv:
    # IEEE 754 square roots are correctly rounded: no libm widening needed.
    return Iv(np.maximum(_dn(np.sqrt(a.lo)), 0.0), _up(np.sqrt(a.hi)))


def _cosh(a: Iv) -> Iv:
    r = Iv(_dn_t(np.cosh(_mig(a))), _up_t(np.cosh(_mag(a))))
    return Iv(np.maximum(r.lo, 1.0), r.hi)


def _through0(fn, lower=-_INF, upper=_INF):
    """An increasing function with fn(0) = 0, whose range lies in [lower, upper]."""
    return lambda a: _clip(_keep_sign(_increasing(fn, a), a), lower, upper)


_ONE = _point(1.0)
_HALF = _point(0.5)
_THREE = _point(3.0)

UNARY_RULES = {
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
        lambda a: Iv(_mig(a), _mag(a)),
        _d_abs,
        None,
    ),
    "sign": (
        lambda a: Iv(np.sign(a.lo), np.sign(a.hi)),
        _steps(_has0),
        None,
    ),
    "floor": (
        lambda a: Iv(np.floor(a.lo), np.floor(a.hi)),
        _steps(lambda a: np.ceil(a.lo) <= a.hi),
        None,
    ),
    "ceil": (
        lambda a: Iv(np.ceil(a.lo), np.ceil(a.hi)),
        _steps(lambda a: np.ceil(a.lo) <= a.hi),
        None,
    ),
}


# -- the tree walk -----------------------------------------------------------------------


class _Walker:
    """Evaluates a tree on boxes as interval duals: (value, gradient or None)."""

    def __init__(self, lo: np.ndarray, hi: np.ndarray, gradient: bool) -> None:
        n = len(lo)
        self.xyz = [Iv(lo[:, k], hi[:, k]) for k in range(3)]
        self.gradient = gradient
        self.undefined = np.zeros(n, dtype=bool)
        self._unit = [_point(np.eye(3)[k][:, None]) for k in range(3)]

    def flag(self, mask) -> None:
        self.undefined = self.undefined | mask

    def walk(self, node: Node):
        if isinstance(node, Const):
            c = node.c
            if not math.isfinite(c):  # e.g. 1e999: not a real number
                self.flag(True)
                return Iv(_dn(c), _up(c)), None
            return _point(c), None
        if isinstance(node, Var):
            return self.xyz[node.i], (self._unit[node.i] if self.gradient else None)
        if isinstance(node, Neg):
            v, g = self.walk(node.a)
            return _neg(v), None if g is None else _neg(g)
        if isinstance(node, Sum):
            return self.sum(node)
        if isinstance(node, Product):
            return self.product(node)
        if isinstance(node, Pow):
            return self.power(node.a, node.b)
        if isinstance(node, Unary):
            return self.unary(node)
        if isinstance(node, Nary):
            return self.nary(node)
        raise TypeError(f"no interval rule for {type(node).__name__}")  # pragma: no cover

    def sum(self, node: Sum):
        total, grad = None, None
        for term, minus in node.terms:
            v, g = self.walk(term)
            if minus:
                v, g = _neg(v), (None if g is None else _neg(g))
            total = v if total is None else _add(total, v)
            grad = g if grad is None else (grad if g is None else _add(grad, g))
        return total, grad

    def product(self, node: Product):
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

    def power(self, base: Node, exponent: Node):
        a, ga = self.walk(base)
        if is_constant(exponent):
            with np.errstate(all="ignore"):
                c = float(point_value(exponent, None))
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

    def unary(self, node: Unary):
        a, ga = self.walk(node.a)
        name = node.name
        if name == "tan":
            v, pole = _tan(a)
            self.flag(pole)
            if ga is None:
                return v, None
            return v, _mul(ga, _recip(_sqr(_cos(a))))
        value, deriv, domain = UNARY_RULES[name]
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

    def nary(self, node: Nary):
        name = node.name
        if name == "pow":
            return self.power(node.args[0], node.args[1])
        duals = [self.walk(n) for n in node.args]
        if name == "atan2":
            return self.atan2(*duals[0], *duals[1])
        if name == "hypot":
            return self.hypot(duals)
        return self.minmax(duals, name == "min")

    def atan2(self, y: Iv, gy, x: Iv, gx):
        origin = _has0(x) & _has0(y)
        self.flag(origin)
        # Off the origin and the branch cut (y = 0, x < 0) the angle of a box is
        # continuous, and its extremes are at corners.
        jump = origin | ((x.lo < 0) & _has0(y))
        c = [np.arctan2(yy, xx) for yy in (y.lo, y.hi) for xx in (x.lo, x.hi)]
        lo = _dn_t(np.minimum(np.minimum(c[0], c[1]), np.minimum(c[2], c[3])))
        hi = _up_t(np.maximum(np.maximum(c[0], c[1]), np.maximum(c[2], c[3])))
        v = _clip(Iv(np.where(jump, -_PI_UP, lo), np.where(jump, _PI_UP, hi)), -_PI_UP, _PI_UP)
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
        """hypot of several arguments as hypot(hypot(a, b), c) ...: the core's rule."""
        out, grad = duals[0]
        for a, g in duals[1:]:
            out, grad = self.hypot2(out, grad, a, g)
        return out, grad

    def hypot2(self, a: Iv, ga, b: Iv, gb):
        out = Iv(
            np.maximum(_dn_t(np.hypot(_mig(a), _mig(b))), 0.0), _up_t(np.hypot(_mag(a), _mag(b)))
        )
        grad = None
        for v, g in ((a, ga), (b, gb)):
            if g is not None:
                t = _mul(g, _clip(_div(v, out), -1.0, 1.0))
                grad = t if grad is None else _add(grad, t)
        return out, grad

    def minmax(self, duals, is_min: bool):
        out, grad = duals[0]
        for v, g in duals[1:]:
            if is_min:
                only_out, only_v = out.hi < v.lo, v.hi < out.lo
                out = Iv(np.minimum(out.lo, v.lo), np.minimum(out.hi, v.hi))
            else:
                only_out, only_v = out.lo > v.hi, v.lo > out.hi
                out = Iv(np.maximum(out.lo, v.lo), np.maximum(out.hi, v.hi))
            if grad is None and g is None:
                continue
            zero = _point(0.0)
            ga = zero if grad is None else grad
            gb = zero if g is None else g
            # Where both branches can be taken, the hull of both gradients.
            grad = _where(only_out, ga, _where(only_v, gb, _hull(ga, gb)))
        return out, grad


def _evaluate(root: Node, lo, hi, gradient: bool):
    n = len(lo)
    walker = _Walker(lo, hi, gradient)
    with np.errstate(all="ignore"):
        v, g = walker.walk(root)
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


def _mean_value(root: Node, lo, hi, flo, fhi, glo, ghi, undefined):
    """Intersect with f(m) + G(X).(X - m), m the box centre, where f is defined."""
    ok = ~undefined & np.isfinite(lo).all(axis=1) & np.isfinite(hi).all(axis=1)
    ok &= np.isfinite(glo).all(axis=1) & np.isfinite(ghi).all(axis=1)
    if not ok.any():
        return flo, fhi
    m = np.where(ok[:, None], np.clip(0.5 * lo + 0.5 * hi, lo, hi), 0.0)
    mlo, mhi, _, _, mundef = _evaluate(root, m, m, gradient=False)
    ok &= ~mundef
    with np.errstate(all="ignore"):
        total = Iv(mlo, mhi)
        for k in range(3):
            dk = _sub(Iv(lo[:, k], hi[:, k]), _point(m[:, k]))
            total = _add(total, _mul(Iv(glo[:, k], ghi[:, k]), dk))
    out_lo = np.where(ok, np.maximum(flo, total.lo), flo)
    out_hi = np.where(ok, np.minimum(fhi, total.hi), fhi)
    return out_lo, out_hi


# -- the entry points ------------------------------------------------------------------------


def bounds(root: Node, program, lo, hi, gradient: bool, mean_value: bool):
    """(flo, fhi, glo, ghi, undefined) over the boxes, as the core's
    ``evaluate_intervals`` gives them (``program`` is not used)."""
    flo, fhi, glo, ghi, undefined = _evaluate(root, lo, hi, gradient or mean_value)
    if mean_value:
        flo, fhi = _mean_value(root, lo, hi, flo, fhi, glo, ghi, undefined)
    if not gradient:
        glo = ghi = None
    return flo, fhi, glo, ghi, undefined


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


def isolate_roots(expr, a, b, min_length: float, pieces=None):
    """``rdmesh.sampling.isolate.isolate_roots`` with the bisection in numpy."""
    a = np.asarray(a, np.float64).reshape(-1, 3)
    b = np.asarray(b, np.float64).reshape(-1, 3)
    n = len(a)
    if pieces is None:
        seg, t0, t1 = np.arange(n), np.zeros(n), np.ones(n)
    else:
        seg, t0, t1 = (np.asarray(x) for x in pieces)
    fs, flo, fhi, ps, plo, phi, boxes = isolate_numpy(expr, a[seg], b[seg], t0, t1, min_length)
    return _isolation(n, seg[fs], flo, fhi, seg[ps], plo, phi, boxes)


#: Pieces kept at one level at most (bounds the memory of a call).
MAX_PIECES = 1 << 21
#: Boxes kept at one level at most, over all facets or cells.
MAX_BOXES = 1 << 21


def isolate_numpy(expr, a, b, t0, t1, min_length: float):
    """What the core's ``isolate_segment_roots`` does, level by level in numpy:
    (found segment, t0, t1, pending segment, t0, t1, boxes)."""
    n = len(a)
    d = b - a
    length = np.sqrt(np.einsum("ij,ij->i", d, d))
    seg = np.arange(n)
    t0, t1 = np.array(t0, np.float64), np.array(t1, np.float64)
    found: list[tuple[np.ndarray, ...]] = []
    pending: list[tuple[np.ndarray, ...]] = []
    boxes = 0
    while len(seg):
        p0 = a[seg] + t0[:, None] * d[seg]
        p1 = a[seg] + t1[:, None] * d[seg]
        enc = expr.interval_gradient(np.minimum(p0, p1), np.maximum(p0, p1), mean_value=True)
        boxes += len(seg)
        has0 = (enc.lo <= 0) & (enc.hi >= 0)
        dlo, dhi = dot_bounds(enc.glo, enc.ghi, d[seg])
        mono = has0 & ~enc.undefined & ((dlo > 0) | (dhi < 0))
        # The ends of monotone pieces: their signs decide.
        ends = np.concatenate([p0[mono], p1[mono]])
        e = expr.interval(ends, ends)
        boxes += len(ends)
        k = int(mono.sum())
        s0 = _sign(e.lo[:k], e.hi[:k], e.undefined[:k])
        s1 = _sign(e.lo[k:], e.hi[k:], e.undefined[k:])
        settled = (s0 != 0) & (s1 != 0)
        idx = np.flatnonzero(mono)
        root = idx[settled & (s0 != s1)]
        found.append((seg[root], t0[root], t1[root]))
        open_ = has0.copy()
        open_[idx[settled]] = False
        # Halve the rest, unless too short (or too many).
        short = (t1 - t0) * length[seg] <= min_length
        stop = open_ & short
        pending.append((seg[stop], t0[stop], t1[stop]))
        go = np.flatnonzero(open_ & ~short)
        if 2 * len(go) > MAX_PIECES:
            pending.append((seg[go], t0[go], t1[go]))
            break
        mid = 0.5 * (t0[go] + t1[go])
        seg = np.repeat(seg[go], 2)
        t0 = np.column_stack([t0[go], mid]).ravel()
        t1 = np.column_stack([mid, t1[go]]).ravel()
    fs, flo, fhi = (np.concatenate(c) for c in zip(*found, strict=True)) if found else _none(3)
    ps, plo, phi = (np.concatenate(c) for c in zip(*pending, strict=True)) if pending else _none(3)
    return fs, flo, fhi, ps, plo, phi, boxes


def _sign(lo: np.ndarray, hi: np.ndarray, undefined: np.ndarray) -> np.ndarray:
    """+1 / -1 where the enclosure proves the sign, 0 where it does not."""
    s = np.where(lo > 0, 1, np.where(hi < 0, -1, 0))
    return np.where(undefined, 0, s)


def _none(k: int) -> tuple[np.ndarray, ...]:
    return (np.zeros(0, np.int64),) + tuple(np.zeros(0) for _ in range(k - 1))


def subdivide(
    expr, vertices, geometry, lo, hi, cell, direction, floor, skip, plane, leaves, seeds
):
    """``rdmesh.topology.proven_cells._subdivide`` (the core's ``prove_boxes``)
    level by level: (failed owners, their unsettled boxes lo, hi, and with
    ``leaves`` each owner's settled boxes as (first, lo, hi), else ())."""
    start = (np.arange(len(lo)), lo, hi) if seeds is None else seed_boxes(seeds, cell, lo, hi)
    failed, blo, bhi, kept = prove_numpy(
        expr, vertices, geometry, *start, len(lo), cell, direction, skip, plane, floor
    )
    return failed, blo, bhi, (kept if leaves else ())


def seed_boxes(seeds, cell, lo, hi):
    """Each owner's first boxes, as (owner, lo, hi): the leaves of its cell cut
    to its box where the cell is seeded, its box elsewhere (what the core's
    ``prove_boxes`` does with seeds)."""
    seeded = seeds.seeded[cell]
    owner, rows = seeds.leaves_of(cell)
    blo = np.maximum(seeds.lo[rows], lo[owner])
    bhi = np.minimum(seeds.hi[rows], hi[owner])
    keep = np.all(blo <= bhi, axis=1)
    own = np.flatnonzero(~seeded)
    return (
        np.concatenate([owner[keep], own]),
        np.concatenate([blo[keep], lo[own]]),
        np.concatenate([bhi[keep], hi[own]]),
    )


def _meets_plane(lo, hi, plane) -> np.ndarray:
    """Boxes that may touch the planes (normal, offset), with a margin for
    rounding: a box that touches its plane is never dropped."""
    a, b = _span(lo, hi, plane[:, :3])
    c = plane[:, 3]
    slack = 1e-12 * (np.abs(a) + np.abs(b) + np.abs(c)) + 1e-300
    return (a <= c + slack) & (b >= c - slack)


def prove_numpy(expr, vertices, geometry, owner, lo, hi, n, cell, direction, skip, plane, floor):
    """What the core's ``prove_boxes`` does, level by level in numpy, from the
    boxes ``lo, hi`` of the ``n`` owners ``owner``: (failed owners, their first
    unsettled boxes, and each owner's settled boxes as (first, lo, hi))."""
    done = np.zeros(n, bool)
    bad_lo, bad_hi, bad_owner = [], [], []
    leaf_lo, leaf_hi, leaf_owner = [], [], []
    while len(lo):
        # One unsettled box makes an owner a violation: drop the rest of it.
        keep = ~done[owner]
        if plane is not None:
            keep &= _meets_plane(lo, hi, plane[owner])
        lo, hi, owner = lo[keep], hi[keep], owner[keep]
        keep = ~outside_cell(
            lo, hi, cell[owner], vertices, geometry, None if skip is None else skip[owner]
        )
        lo, hi, owner = lo[keep], hi[keep], owner[keep]
        if not len(lo):
            break
        enc = expr.interval_gradient(lo, hi, mean_value=True)
        dlo, dhi = dot_bounds(enc.glo, enc.ghi, direction[owner])
        settled = ~enc.undefined & ((dlo > 0) | (dhi < 0))
        leaf_lo.append(lo[settled])
        leaf_hi.append(hi[settled])
        leaf_owner.append(owner[settled])
        open_ = (enc.lo <= 0) & (enc.hi >= 0) & ~settled
        lo, hi, owner = lo[open_], hi[open_], owner[open_]
        side = hi - lo
        small = side.max(axis=1) <= floor[owner]
        if small.any() or 2 * len(lo) > MAX_BOXES:
            stop = small if 2 * len(lo) <= MAX_BOXES else np.ones(len(lo), bool)
            bad_lo.append(lo[stop])
            bad_hi.append(hi[stop])
            bad_owner.append(owner[stop])
            done[owner[stop]] = True
            stop |= done[owner]
            lo, hi, owner = lo[~stop], hi[~stop], owner[~stop]
            side = side[~stop]
        # Halve along the longest side.
        axis = np.argmax(side, axis=1)
        rows = np.arange(len(lo))
        cut = lo[rows, axis] + 0.5 * side[rows, axis]
        hi1 = hi.copy()
        hi1[rows, axis] = cut
        lo2 = lo.copy()
        lo2[rows, axis] = cut
        lo, hi = np.concatenate([lo, lo2]), np.concatenate([hi1, hi])
        owner = np.concatenate([owner, owner])
    # Settled boxes by owner, none for a violation.
    klo = np.concatenate([np.zeros((0, 3)), *leaf_lo])
    khi = np.concatenate([np.zeros((0, 3)), *leaf_hi])
    kown = np.concatenate([np.zeros(0, np.int64), *leaf_owner])
    keep = ~done[kown]
    order = np.argsort(kown[keep], kind="stable")
    kept = (
        np.r_[0, np.cumsum(np.bincount(kown[keep], minlength=n))],
        klo[keep][order],
        khi[keep][order],
    )
    if not bad_lo:
        return np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 3)), kept
    blo, bhi, bown = (np.concatenate(x) for x in (bad_lo, bad_hi, bad_owner))
    # One violation per owner: its first unsettled box.
    failed, at = np.unique(bown, return_index=True)
    return failed, blo[at], bhi[at], kept


def _span(lo, hi, w) -> tuple[np.ndarray, np.ndarray]:
    """Least and greatest ``x . w`` over the boxes."""
    a = np.where(w > 0, lo, hi)
    b = np.where(w > 0, hi, lo)
    return np.einsum("ij,ij->i", a, w), np.einsum("ij,ij->i", b, w)


def outside_cell(lo, hi, p_ids, vertices, geometry, skip=None) -> np.ndarray:
    """Boxes wholly beyond the bisector of ``p`` and one of its neighbours
    (other than ``skip``): outside the Voronoi cell of ``p`` (in the core, with
    a relative margin so that rounding never drops a box that touches the cell)."""
    owner = np.broadcast_to(np.asarray(p_ids, dtype=np.int64), (len(lo),))
    if skip is not None:
        skip = np.broadcast_to(np.asarray(skip, dtype=np.int64), (len(lo),))
    out = boxes_outside_cells(lo, hi, owner, vertices, geometry.offsets, geometry.neighbour, skip)
    return out.view(bool)
