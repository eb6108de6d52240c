"""Parsing expression text into the expression tree (:mod:`~rdmesh.surfaces.ir`).

The text is parsed with Python's :mod:`ast` module and checked against a
whitelist; it is never passed to ``eval``. :func:`parse` is the work behind
:func:`rdmesh.surfaces.expressions.parse_expression`, which documents the
grammar.
"""

from __future__ import annotations

import ast

import numpy as np

from .._errors import ExpressionError
from .ir import (
    ALIASES,
    CONSTANTS,
    FUNCTIONS,
    NARY,
    UNARY,
    VARIABLES,
    Const,
    Nary,
    Neg,
    Node,
    Pow,
    Product,
    Sum,
    Unary,
    Var,
)

#: Longest expression text accepted, in characters.
MAX_LENGTH = 10_000
#: Deepest nesting of operations and calls accepted. Chains of ``+ -`` and of
#: ``* /`` count as one level, so long polynomials are fine.
MAX_DEPTH = 100

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

    def compile(self, node: ast.AST, depth: int = 0) -> Node:
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
                return Const(np.float64(float(v)))
            except OverflowError:
                self.fail("number too large", node)
        if isinstance(node, ast.Name):
            return self.name(node)
        if isinstance(node, ast.UnaryOp):
            if isinstance(node.op, ast.USub):
                return Neg(self.compile(node.operand, d))
            if isinstance(node.op, ast.UAdd):
                return self.compile(node.operand, d)
            self.fail(f"operator {_OPERATORS[type(node.op)]!r} is not allowed", node)
        if isinstance(node, ast.BinOp):
            return self.binop(node, d)
        if isinstance(node, ast.Call):
            return self.call(node, d)
        reason = _REFUSED.get(type(node), f"{type(node).__name__} is not allowed")
        self.fail(reason, node)

    def name(self, node: ast.Name) -> Node:
        n = node.id
        if n in VARIABLES:
            self.variables.add(n)
            return Var(VARIABLES.index(n))
        if n in CONSTANTS:
            return Const(np.float64(CONSTANTS[n]))
        if n in FUNCTIONS:
            self.fail(f"{n!r} is a function: call it as {n}(...)", node)
        self.fail(
            f"unknown name {n!r}; use x, y, z, the constants {', '.join(CONSTANTS)} "
            "and function calls",
            node,
        )

    def binop(self, node: ast.BinOp, d: int) -> Node:
        op = type(node.op)
        if op in (ast.Add, ast.Sub):
            return Sum(self.chain(node, (ast.Add, ast.Sub), ast.Sub, d))
        if op in (ast.Mult, ast.Div):
            return Product(self.chain(node, (ast.Mult, ast.Div), ast.Div, d))
        if op is ast.Pow:
            return Pow(self.compile(node.left, d), self.compile(node.right, d))
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

    def call(self, node: ast.Call, d: int) -> Node:
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
        key = ALIASES.get(name, name)
        n = len(node.args)
        least, most = (1, 1) if key in UNARY else NARY[key]
        if n < least or (most is not None and n > most):
            want = f"{least}" if least == most else f"at least {least}"
            plural = "" if want == "1" else "s"
            self.fail(f"{name}() takes {want} argument{plural}, got {n}", node)
        args = [self.compile(a, d) for a in node.args]
        if key in UNARY:
            return Unary(key, args[0])
        return Nary(key, args)


def parse(text: str) -> tuple[str, Node, frozenset]:
    """The tree of an expression text: ``(text stripped, root, variables used)``.

    Raises :class:`~rdmesh.ExpressionError` for anything but an accepted
    expression (see :func:`~rdmesh.surfaces.expressions.parse_expression`).
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
    return stripped, root, frozenset(compiler.variables)
