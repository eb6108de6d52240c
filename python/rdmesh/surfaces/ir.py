"""The expression tree: one node per operation of a parsed expression.

This is the one home of the tree that the parser
(:mod:`~rdmesh.surfaces._parse`) builds and that every evaluator reads: point
values and gradients (:mod:`~rdmesh.surfaces.pointwise`) and the core's
interval programs (:mod:`~rdmesh.surfaces.interval_program`). Nodes are plain
data; they know nothing of how they are evaluated, and this module imports no
other part of rdmesh.

The grammar's names live here too: the variables, the named constants and
the functions with their arities and aliases.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: The coordinates, in axis order.
VARIABLES = ("x", "y", "z")

#: Named constants.
CONSTANTS: dict[str, float] = {"pi": math.pi, "e": math.e, "tau": math.tau}

#: Functions of one argument.
UNARY: tuple[str, ...] = (
    "sin", "cos", "tan", "asin", "acos", "atan", "sinh", "cosh", "tanh", "asinh", "acosh",
    "atanh", "exp", "expm1", "log", "log1p", "log2", "log10", "sqrt", "cbrt", "abs", "sign",
    "floor", "ceil",
)  # fmt: skip

#: Functions of several arguments: name -> (least, most or None) arguments.
NARY: dict[str, tuple[int, int | None]] = {
    "min": (2, None),
    "max": (2, None),
    "hypot": (2, None),
    "atan2": (2, 2),
    "pow": (2, 2),
}

#: Other spellings of functions.
ALIASES: dict[str, str] = {
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
FUNCTIONS: tuple[str, ...] = tuple(sorted({*UNARY, *NARY, *ALIASES}))


class Node:
    """A node of the expression tree."""


@dataclass
class Const(Node):
    """A number, as float64."""

    c: np.float64


@dataclass
class Var(Node):
    """Coordinate ``i`` (0, 1, 2 for x, y, z)."""

    i: int


@dataclass
class Neg(Node):
    """``-a``."""

    a: Node


@dataclass
class Sum(Node):
    """A chain of ``+`` and ``-``: ``(term, subtract)`` pairs (the first never subtracts)."""

    terms: list[tuple[Node, bool]]


@dataclass
class Product(Node):
    """A chain of ``*`` and ``/``: ``(factor, divide)`` pairs (the first never divides)."""

    factors: list[tuple[Node, bool]]


@dataclass
class Pow(Node):
    """``a ** b``."""

    a: Node
    b: Node


@dataclass
class Unary(Node):
    """A function of one argument, by its name in :data:`UNARY`."""

    name: str
    a: Node


@dataclass
class Nary(Node):
    """A function of several arguments, by its name in :data:`NARY`."""

    name: str
    args: list[Node]


def children(node: Node) -> list[Node]:
    """The node's operands, in order."""
    if isinstance(node, (Const, Var)):
        return []
    if isinstance(node, (Neg, Unary)):
        return [node.a]
    if isinstance(node, Sum):
        return [n for n, _ in node.terms]
    if isinstance(node, Product):
        return [n for n, _ in node.factors]
    if isinstance(node, Pow):
        return [node.a, node.b]
    if isinstance(node, Nary):
        return list(node.args)
    raise TypeError(f"not an expression node: {type(node).__name__}")


def is_constant(node: Node) -> bool:
    """True when the sub-tree uses no variable."""
    if isinstance(node, Var):
        return False
    return all(is_constant(n) for n in children(node))
