"""Values and exact gradients of an expression tree at points, in numpy.

:func:`value` evaluates a tree (:mod:`~rdmesh.surfaces.ir`) on the columns
``(x, y, z)`` of ``N`` points; :func:`dual` also gives the gradient, by
forward-mode differentiation over the tree (one pass, no symbolic blow-up).
``abs``, ``min`` and ``max`` use the derivative of the active branch (``abs``
has derivative 0 at 0); ``sign``, ``floor`` and ``ceil`` have derivative 0.
Arithmetic is IEEE float64 throughout: a pole gives ``inf``, a point outside
a domain ``nan``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from .ir import Const, Nary, Neg, Node, Pow, Product, Sum, Unary, Var, children

# A gradient is None (identically zero) or an array broadcastable to (3, N).
Grad = np.ndarray | None


def _sq(u):
    return u * u


# Unary functions: name -> (value, derivative or None when it is 0 almost everywhere).
# The interval rules of the core (cpp/interval_eval.cpp) retrace these derivative
# formulas, so that an enclosure on a point box holds the rounded derivative too.
UNARY_FUNCTIONS: dict[str, tuple[Callable, Callable | None]] = {
    "sin": (np.sin, np.cos),
    "cos": (np.cos, lambda u: -np.sin(u)),
    "tan": (np.tan, lambda u: 1.0 / _sq(np.cos(u))),
    "asin": (np.arcsin, lambda u: 1.0 / np.sqrt(1.0 - u * u)),
    "acos": (np.arccos, lambda u: -1.0 / np.sqrt(1.0 - u * u)),
    "atan": (np.arctan, lambda u: 1.0 / (1.0 + u * u)),
    "sinh": (np.sinh, np.cosh),
    "cosh": (np.cosh, np.sinh),
    "tanh": (np.tanh, lambda u: 1.0 - _sq(np.tanh(u))),
    "asinh": (np.arcsinh, lambda u: 1.0 / np.sqrt(u * u + 1.0)),
    "acosh": (np.arccosh, lambda u: 1.0 / np.sqrt(u * u - 1.0)),
    "atanh": (np.arctanh, lambda u: 1.0 / (1.0 - u * u)),
    "exp": (np.exp, np.exp),
    "expm1": (np.expm1, np.exp),
    "log": (np.log, lambda u: 1.0 / u),
    "log1p": (np.log1p, lambda u: 1.0 / (1.0 + u)),
    "log2": (np.log2, lambda u: 1.0 / (u * math.log(2.0))),
    "log10": (np.log10, lambda u: 1.0 / (u * math.log(10.0))),
    "sqrt": (np.sqrt, lambda u: 0.5 / np.sqrt(u)),
    "cbrt": (np.cbrt, lambda u: 1.0 / (3.0 * _sq(np.cbrt(u)))),
    "abs": (np.abs, np.sign),
    "sign": (np.sign, None),
    "floor": (np.floor, None),
    "ceil": (np.ceil, None),
}

_UNIT = np.eye(3)[:, :, None]  # _UNIT[i] is the (3, 1) gradient of coordinate i

#: Positive integer exponents up to this size are computed by multiplications:
#: numpy's pow costs about ten times as much (45 against 5 ns a point for x**4).
#: The result is within a few ulps of pow's (the interval rules widen pow by
#: 8 to 16 ulps, so their enclosures still hold it).
MULTIPLY_UP_TO = 16


def _gadd(a: Grad, b: Grad) -> Grad:
    if a is None:
        return b
    if b is None:
        return a
    return a + b


def _gscale(g: Grad, s) -> Grad:
    return None if g is None else g * s


def _gwhere(cond, a: Grad, b: Grad) -> Grad:
    if a is None and b is None:
        return None
    c = np.asarray(cond)
    if c.ndim:
        c = c[None]
    return np.where(c, 0.0 if a is None else a, 0.0 if b is None else b)


def power(a, b):
    """a**b, by repeated squaring when b is a small positive integer constant
    (negative ones stay with pow: 1 / x**n loses precision where x**n is subnormal)."""
    if np.ndim(b) == 0 and math.isfinite(b) and b == math.floor(b) and 0 < b <= MULTIPLY_UP_TO:
        n = int(b)
        out, base = None, a
        while n:
            if n & 1:
                out = base if out is None else out * base
            n >>= 1
            if n:
                base = base * base
        return out
    return a**b


def _pow_dual(a, ga, b, gb):
    out = power(a, b)
    grad = None
    if ga is not None:
        if gb is None and np.ndim(b) == 0 and b == 0:
            pass  # u**0 is constant
        else:
            grad = ga * (b * power(a, b - 1.0))
    if gb is not None:
        grad = _gadd(grad, gb * (out * np.log(a)))
    return out, grad


_FOLD = {"min": np.minimum, "max": np.maximum, "hypot": np.hypot}


def value(node: Node, xyz):
    """The value of the tree at points with coordinate columns ``xyz``
    (``None`` will do for a constant tree)."""
    kind = type(node)
    if kind is Const:
        return node.c
    if kind is Var:
        return xyz[node.i]
    return combine_value(node, [value(c, xyz) for c in children(node)])


def combine_value(node: Node, vals: list):
    """The value of ``node`` from its operands' values ``vals`` (in the order
    of :func:`~rdmesh.surfaces.ir.children`): one step of :func:`value`, for
    evaluators that walk the tree themselves."""
    kind = type(node)
    if kind is Neg:
        return -vals[0]
    if kind is Sum:
        total = None
        for v, (_, minus) in zip(vals, node.terms, strict=True):
            total = (-v if minus else v) if total is None else (total - v if minus else total + v)
        return total
    if kind is Product:
        out = vals[0]
        for v, (_, divide) in zip(vals[1:], node.factors[1:], strict=True):
            out = out / v if divide else out * v
        return out
    if kind is Pow:
        return power(vals[0], vals[1])
    if kind is Unary:
        return UNARY_FUNCTIONS[node.name][0](vals[0])
    if node.name == "atan2":
        return np.arctan2(vals[0], vals[1])
    if node.name == "pow":
        return power(vals[0], vals[1])
    op, out = _FOLD[node.name], vals[0]
    for v in vals[1:]:
        out = op(out, v)
    return out


def dual(node: Node, xyz) -> tuple:
    """``(value, gradient)`` of the tree at points with coordinate columns
    ``xyz``; the gradient is None (identically zero) or broadcastable to
    ``(3, N)``."""
    kind = type(node)
    if kind is Const:
        return node.c, None
    if kind is Var:
        return xyz[node.i], _UNIT[node.i]
    return combine_dual(node, [dual(c, xyz) for c in children(node)])


def combine_dual(node: Node, duals: list) -> tuple:
    """``(value, gradient)`` of ``node`` from its operands' ``duals`` (in the
    order of :func:`~rdmesh.surfaces.ir.children`): one step of :func:`dual`."""
    kind = type(node)
    if kind is Neg:
        v, g = duals[0]
        return -v, _gscale(g, -1.0)
    if kind is Sum:
        total, grad = None, None
        for (v, g), (_, minus) in zip(duals, node.terms, strict=True):
            if minus:
                v, g = -v, _gscale(g, -1.0)
            total = v if total is None else total + v
            grad = _gadd(grad, g)
        return total, grad
    if kind is Product:
        out, grad = duals[0]
        for (v, g), (_, divide) in zip(duals[1:], node.factors[1:], strict=True):
            if divide:
                out = out / v
                # d(u/v) = (du - (u/v) dv) / v
                grad = _gscale(_gadd(grad, _gscale(g, -out)), 1.0 / v)
            else:
                grad = _gadd(_gscale(grad, v), _gscale(g, out))
                out = out * v
        return out, grad
    if kind is Pow:
        return _pow_dual(*duals[0], *duals[1])
    if kind is Unary:
        f, df = UNARY_FUNCTIONS[node.name]
        a, ga = duals[0]
        if ga is None or df is None:
            return f(a), None
        return f(a), ga * df(a)
    return _nary_dual(node, duals)


def _nary_dual(node: Nary, duals: list) -> tuple:
    if node.name == "pow":
        return _pow_dual(*duals[0], *duals[1])
    if node.name == "atan2":
        (y, gy), (x, gx) = duals
        r2 = x * x + y * y
        grad = _gadd(_gscale(gy, x / r2), _gscale(gx, -y / r2))
        return np.arctan2(y, x), grad
    if node.name == "hypot":
        out = duals[0][0]
        for v, _ in duals[1:]:
            out = np.hypot(out, v)
        grad = None
        for v, g in duals:
            grad = _gadd(grad, _gscale(g, v / out))
        return out, grad
    # min / max: the gradient of the branch taken (the first on ties).
    out, grad = duals[0]
    for v, g in duals[1:]:
        keep = out <= v if node.name == "min" else out >= v
        grad = _gwhere(keep, grad, g)
        out = np.where(keep, out, v)
    return out, grad
