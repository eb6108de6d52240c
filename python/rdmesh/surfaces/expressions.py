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
syntax tree (one pass, no symbolic blow-up). ``abs``, ``min`` and ``max``
use the derivative of the active branch (``abs`` has derivative 0 at 0).
Where the exact derivative is not finite (``sqrt`` at 0, say), those rows
fall back to central differences.

:meth:`Expression.interval` and :meth:`Expression.interval_gradient` bound the
value and the gradient over boxes, with outward rounding
(:mod:`rdmesh.surfaces.intervals`).
"""

from __future__ import annotations

import ast
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .._errors import RdmeshError

if TYPE_CHECKING:
    from .intervals import Enclosure, GradientEnclosure

__all__ = [
    "CONSTANTS",
    "FUNCTIONS",
    "MAX_DEPTH",
    "MAX_LENGTH",
    "Expression",
    "ExpressionError",
    "parse_expression",
]

#: Longest expression text accepted, in characters.
MAX_LENGTH = 10_000
#: Deepest nesting of operations and calls accepted. Chains of ``+ -`` and of
#: ``* /`` count as one level, so long polynomials are fine.
MAX_DEPTH = 100

VARIABLES = ("x", "y", "z")

#: Named constants.
CONSTANTS: dict[str, float] = {"pi": math.pi, "e": math.e, "tau": math.tau}


class ExpressionError(RdmeshError, ValueError):
    """The text is not an accepted expression.

    Attributes
    ----------
    text : str
        The expression text.
    reason : str
        What is wrong, e.g. ``"unknown name 'os'"``.
    column : int or None
        1-based column of the offending part, when known.
    """

    def __init__(self, text: str, reason: str, column: int | None = None) -> None:
        shown = text if len(text) <= 60 else text[:57] + "..."
        where = f" (column {column})" if column is not None else ""
        super().__init__(f"invalid expression {shown!r}: {reason}{where}")
        self.text = text
        self.reason = reason
        self.column = column


# -- functions ------------------------------------------------------------------

# A gradient is None (identically zero) or an array broadcastable to (3, N).
Grad = np.ndarray | None


def _sq(u):
    return u * u


# Unary functions: name -> (value, derivative or None when it is 0 almost everywhere).
_UNARY: dict[str, tuple[Callable, Callable | None]] = {
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

# Functions of several arguments: name -> (least, most) number of arguments.
_NARY: dict[str, tuple[int, int | None]] = {
    "min": (2, None),
    "max": (2, None),
    "hypot": (2, None),
    "atan2": (2, 2),
    "pow": (2, 2),
}

_ALIASES = {
    "arcsin": "asin",
    "arccos": "acos",
    "arctan": "atan",
    "arcsinh": "asinh",
    "arccosh": "acosh",
    "arctanh": "atanh",
    "arctan2": "atan2",
    "fabs": "abs",
    "ln": "log",
}

#: Every function name accepted (aliases included), sorted.
FUNCTIONS: tuple[str, ...] = tuple(sorted({*_UNARY, *_NARY, *_ALIASES}))


# -- the compiled tree ------------------------------------------------------------

_UNIT = np.eye(3)[:, :, None]  # _UNIT[i] is the (3, 1) gradient of coordinate i


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


class _Node:
    def value(self, xyz):  # pragma: no cover - abstract
        raise NotImplementedError

    def dual(self, xyz) -> tuple:  # pragma: no cover - abstract
        """(value, gradient) with the gradient None or broadcastable to (3, N)."""
        raise NotImplementedError


@dataclass
class _Const(_Node):
    c: np.float64

    def value(self, xyz):
        return self.c

    def dual(self, xyz):
        return self.c, None


@dataclass
class _Var(_Node):
    i: int

    def value(self, xyz):
        return xyz[self.i]

    def dual(self, xyz):
        return xyz[self.i], _UNIT[self.i]


@dataclass
class _Neg(_Node):
    a: _Node

    def value(self, xyz):
        return -self.a.value(xyz)

    def dual(self, xyz):
        v, g = self.a.dual(xyz)
        return -v, _gscale(g, -1.0)


@dataclass
class _Sum(_Node):
    terms: list[tuple[_Node, bool]]  # (term, subtract)

    def value(self, xyz):
        total = None
        for node, minus in self.terms:
            v = node.value(xyz)
            total = (-v if minus else v) if total is None else (total - v if minus else total + v)
        return total

    def dual(self, xyz):
        total, grad = None, None
        for node, minus in self.terms:
            v, g = node.dual(xyz)
            if minus:
                v, g = -v, _gscale(g, -1.0)
            total = v if total is None else total + v
            grad = _gadd(grad, g)
        return total, grad


@dataclass
class _Product(_Node):
    factors: list[tuple[_Node, bool]]  # (factor, divide); the first never divides

    def value(self, xyz):
        out = self.factors[0][0].value(xyz)
        for node, div in self.factors[1:]:
            v = node.value(xyz)
            out = out / v if div else out * v
        return out

    def dual(self, xyz):
        out, grad = self.factors[0][0].dual(xyz)
        for node, div in self.factors[1:]:
            v, g = node.dual(xyz)
            if div:
                out = out / v
                # d(u/v) = (du - (u/v) dv) / v
                grad = _gscale(_gadd(grad, _gscale(g, -out)), 1.0 / v)
            else:
                grad = _gadd(_gscale(grad, v), _gscale(g, out))
                out = out * v
        return out, grad


#: Positive integer exponents up to this size are computed by multiplications:
#: numpy's pow costs about ten times as much (45 against 5 ns a point for x**4).
#: The result is within a few ulps of pow's (the interval rules widen pow by
#: 8 to 16 ulps, so their enclosures still hold it).
_MULTIPLY_UP_TO = 16


def _power(a, b):
    """a**b, by repeated squaring when b is a small positive integer constant
    (negative ones stay with pow: 1 / x**n loses precision where x**n is subnormal)."""
    if np.ndim(b) == 0 and math.isfinite(b) and b == math.floor(b) and 0 < b <= _MULTIPLY_UP_TO:
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
    out = _power(a, b)
    grad = None
    if ga is not None:
        if gb is None and np.ndim(b) == 0 and b == 0:
            pass  # u**0 is constant
        else:
            grad = ga * (b * _power(a, b - 1.0))
    if gb is not None:
        grad = _gadd(grad, gb * (out * np.log(a)))
    return out, grad


@dataclass
class _Pow(_Node):
    a: _Node
    b: _Node

    def value(self, xyz):
        return _power(self.a.value(xyz), self.b.value(xyz))

    def dual(self, xyz):
        a, ga = self.a.dual(xyz)
        b, gb = self.b.dual(xyz)
        return _pow_dual(a, ga, b, gb)


@dataclass
class _Unary(_Node):
    name: str
    a: _Node

    def value(self, xyz):
        return _UNARY[self.name][0](self.a.value(xyz))

    def dual(self, xyz):
        f, df = _UNARY[self.name]
        a, ga = self.a.dual(xyz)
        if ga is None or df is None:
            return f(a), None
        return f(a), ga * df(a)


@dataclass
class _Nary(_Node):
    name: str
    args: list[_Node]

    def value(self, xyz):
        vals = [a.value(xyz) for a in self.args]
        if self.name == "atan2":
            return np.arctan2(vals[0], vals[1])
        if self.name == "pow":
            return _power(vals[0], vals[1])
        op = {"min": np.minimum, "max": np.maximum, "hypot": np.hypot}[self.name]
        out = vals[0]
        for v in vals[1:]:
            out = op(out, v)
        return out

    def dual(self, xyz):
        duals = [a.dual(xyz) for a in self.args]
        if self.name == "pow":
            return _pow_dual(*duals[0], *duals[1])
        if self.name == "atan2":
            (y, gy), (x, gx) = duals
            r2 = x * x + y * y
            grad = _gadd(_gscale(gy, x / r2), _gscale(gx, -y / r2))
            return np.arctan2(y, x), grad
        if self.name == "hypot":
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
            keep = out <= v if self.name == "min" else out >= v
            grad = _gwhere(keep, grad, g)
            out = np.where(keep, out, v)
        return out, grad


# -- parsing --------------------------------------------------------------------------

_OPERATORS = {
    ast.Add: "+",
    ast.Sub: "-",
    ast.Mult: "*",
    ast.Div: "/",
    ast.Pow: "**",
    ast.FloorDiv: "//",
    ast.Mod: "%",
    ast.MatMult: "@",
    ast.LShift: "<<",
    ast.RShift: ">>",
    ast.BitOr: "|",
    ast.BitAnd: "&",
    ast.BitXor: "^",
    ast.Invert: "~",
    ast.Not: "not",
}

_REFUSED = {
    ast.Attribute: "attribute access is not allowed",
    ast.Subscript: "indexing and slicing are not allowed",
    ast.Compare: "comparisons are not allowed",
    ast.BoolOp: "'and' and 'or' are not allowed",
    ast.IfExp: "conditional expressions are not allowed",
    ast.Lambda: "lambda is not allowed",
    ast.NamedExpr: "assignment (:=) is not allowed",
    ast.JoinedStr: "f-strings are not allowed",
    ast.List: "lists are not allowed",
    ast.Tuple: "tuples are not allowed",
    ast.Set: "sets are not allowed",
    ast.Dict: "dictionaries are not allowed",
    ast.ListComp: "comprehensions are not allowed",
    ast.SetComp: "comprehensions are not allowed",
    ast.DictComp: "comprehensions are not allowed",
    ast.GeneratorExp: "generator expressions are not allowed",
    ast.Starred: "starred arguments are not allowed",
    ast.Await: "await is not allowed",
    ast.Yield: "yield is not allowed",
    ast.YieldFrom: "yield is not allowed",
    ast.Slice: "indexing and slicing are not allowed",
}


class _Compiler:
    def __init__(self, text: str) -> None:
        self.text = text
        self.variables: set[str] = set()

    def fail(self, reason: str, node: ast.AST | None = None):
        col = getattr(node, "col_offset", None)
        raise ExpressionError(self.text, reason, None if col is None else col + 1)

    def compile(self, node: ast.AST, depth: int = 0) -> _Node:
        if depth > MAX_DEPTH:
            self.fail(f"expression is nested more than {MAX_DEPTH} levels deep", node)
        d = depth + 1
        if isinstance(node, ast.Constant):
            v = node.value
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                what = {
                    str: "strings are",
                    bytes: "bytes are",
                    complex: "complex numbers are",
                    bool: "True and False are",
                }.get(type(v), f"{v!r} is")
                self.fail(f"{what} not allowed; use real numbers", node)
            try:
                return _Const(np.float64(float(v)))
            except OverflowError:
                self.fail("number too large", node)
        if isinstance(node, ast.Name):
            return self.name(node)
        if isinstance(node, ast.UnaryOp):
            if isinstance(node.op, ast.USub):
                return _Neg(self.compile(node.operand, d))
            if isinstance(node.op, ast.UAdd):
                return self.compile(node.operand, d)
            self.fail(f"operator {_OPERATORS[type(node.op)]!r} is not allowed", node)
        if isinstance(node, ast.BinOp):
            return self.binop(node, d)
        if isinstance(node, ast.Call):
            return self.call(node, d)
        reason = _REFUSED.get(type(node), f"{type(node).__name__} is not allowed")
        self.fail(reason, node)

    def name(self, node: ast.Name) -> _Node:
        n = node.id
        if n in VARIABLES:
            self.variables.add(n)
            return _Var(VARIABLES.index(n))
        if n in CONSTANTS:
            return _Const(np.float64(CONSTANTS[n]))
        if n in FUNCTIONS:
            self.fail(f"{n!r} is a function: call it as {n}(...)", node)
        self.fail(
            f"unknown name {n!r}; use x, y, z, the constants {', '.join(CONSTANTS)} "
            "and function calls",
            node,
        )

    def binop(self, node: ast.BinOp, d: int) -> _Node:
        op = type(node.op)
        if op in (ast.Add, ast.Sub):
            return _Sum(self.chain(node, (ast.Add, ast.Sub), ast.Sub, d))
        if op in (ast.Mult, ast.Div):
            return _Product(self.chain(node, (ast.Mult, ast.Div), ast.Div, d))
        if op is ast.Pow:
            return _Pow(self.compile(node.left, d), self.compile(node.right, d))
        hint = "; use ** for powers" if op is ast.BitXor else ""
        self.fail(f"operator {_OPERATORS.get(op, op.__name__)!r} is not allowed{hint}", node)

    def chain(self, node: ast.BinOp, ops: tuple, inverse: type, d: int) -> list:
        """Flatten a left-nested chain such as ``a - b + c`` into one level."""
        items = []
        while isinstance(node, ast.BinOp) and isinstance(node.op, ops):
            items.append((node.right, isinstance(node.op, inverse)))
            node = node.left
        items.append((node, False))
        return [(self.compile(n, d), inv) for n, inv in reversed(items)]

    def call(self, node: ast.Call, d: int) -> _Node:
        if isinstance(node.func, ast.Attribute):
            self.fail("attribute access is not allowed", node.func)
        if not isinstance(node.func, ast.Name):
            self.fail("only the named functions can be called", node.func)
        name = node.func.id
        if name not in FUNCTIONS:
            self.fail(f"unknown function {name!r}", node.func)
        if node.keywords:
            self.fail("keyword arguments are not allowed", node.keywords[0].value)
        for a in node.args:
            if isinstance(a, ast.Starred):
                self.fail("starred arguments are not allowed", a)
        key = _ALIASES.get(name, name)
        n = len(node.args)
        least, most = (1, 1) if key in _UNARY else _NARY[key]
        if n < least or (most is not None and n > most):
            want = f"{least}" if least == most else f"at least {least}"
            plural = "" if want == "1" else "s"
            self.fail(f"{name}() takes {want} argument{plural}, got {n}", node)
        args = [self.compile(a, d) for a in node.args]
        if key in _UNARY:
            return _Unary(key, args[0])
        return _Nary(key, args)


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
    _root: _Node
    # Boxes bounded so far (a mutable cell: the dataclass is frozen).
    _boxes: list = field(default_factory=lambda: [0], repr=False)
    # The core's interval program, compiled on first use (a mutable cell).
    _program: list = field(default_factory=list, repr=False)

    @property
    def interval_evaluations(self) -> int:
        """Boxes (or segments, or points) bounded by interval arithmetic so far."""
        return self._boxes[0]

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Values at ``(N, 3)`` points, ``(N,)`` float64 (NaN/inf where undefined)."""
        xyz, n = _columns(points)
        with np.errstate(all="ignore"):
            v = self._root.value(xyz)
        return np.array(np.broadcast_to(np.asarray(v, dtype=np.float64), (n,)))

    def gradient(self, points: np.ndarray, step: float = 1e-6) -> np.ndarray:
        """Exact gradient at ``(N, 3)`` points, ``(N, 3)`` float64.

        Rows where the exact derivative is not finite (e.g. ``sqrt`` at 0) are
        replaced by central differences with the given ``step``.
        """
        xyz, n = _columns(points)
        with np.errstate(all="ignore"):
            _, g = self._root.dual(xyz)
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

    def interval(self, lo: np.ndarray, hi: np.ndarray, *, mean_value: bool = False) -> Enclosure:
        """Bounds of the expression over ``(n, 3)`` boxes ``[lo, hi]``.

        Returns an :class:`~rdmesh.surfaces.intervals.Enclosure`
        ``(lo, hi, undefined)`` of ``(n,)`` arrays, rounded outwards; see
        :func:`rdmesh.surfaces.intervals.interval`.
        """
        from .intervals import interval

        out = interval(self, lo, hi, mean_value=mean_value)
        self.count_boxes(len(out.lo))
        return out

    def interval_gradient(
        self, lo: np.ndarray, hi: np.ndarray, *, mean_value: bool = False
    ) -> GradientEnclosure:
        """Bounds of the expression and of its gradient over ``(n, 3)`` boxes.

        Returns a :class:`~rdmesh.surfaces.intervals.GradientEnclosure`
        ``(lo, hi, glo, ghi, undefined)``; see
        :func:`rdmesh.surfaces.intervals.interval_gradient`.
        """
        from .intervals import interval_gradient

        out = interval_gradient(self, lo, hi, mean_value=mean_value)
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
    if not isinstance(text, str):
        raise ExpressionError(repr(text), f"expected a string, got {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(text, f"longer than {MAX_LENGTH} characters ({len(text)})")
    # Line breaks are blanks, so that long expressions can be wrapped.
    stripped = " ".join(text.split("\n")).replace("\r", " ").replace("\t", " ").strip()
    if not stripped:
        raise ExpressionError(text, "empty expression")
    try:
        tree = ast.parse(stripped, mode="eval")
    except SyntaxError as exc:
        msg = (exc.msg or "invalid syntax").split(" (", 1)[0]
        col = exc.offset if exc.lineno == 1 else None
        if col is not None and (col < 1 or col > len(stripped)):
            col, msg = None, f"{msg} at the end"
        raise ExpressionError(stripped, f"syntax error: {msg}", col) from None
    except (RecursionError, MemoryError):
        raise ExpressionError(stripped, "expression is nested too deeply") from None
    except ValueError as exc:  # e.g. null bytes
        raise ExpressionError(stripped, str(exc)) from None
    compiler = _Compiler(stripped)
    try:
        root = compiler.compile(tree.body)
    except RecursionError:
        raise ExpressionError(stripped, "expression is nested too deeply") from None
    return Expression(stripped, frozenset(compiler.variables), root)
