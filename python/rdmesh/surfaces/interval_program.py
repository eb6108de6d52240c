"""Expression trees as straight-line programs for the core's interval evaluator.

:func:`compile_program` turns an expression tree (:mod:`~rdmesh.surfaces.ir`)
into one instruction per operation (``(op, a, b)`` rows and a constant per
row; the result of row ``i`` is register ``i``), which
``rdmesh.core.evaluate_intervals`` runs box after box in C++ as interval dual
numbers (:mod:`rdmesh.surfaces.intervals` states what the bounds guarantee).
The opcodes are the core's own (``rdmesh.core.INTERVAL_OPS``, by name: the
arithmetic operations and every function of the grammar).
"""

from __future__ import annotations

import numpy as np

from ..core import INTERVAL_OPS
from .ir import Const, Nary, Neg, Node, Pow, Product, Sum, Unary, Var, is_constant
from .pointwise import value

_OP = INTERVAL_OPS


class _Assembler:
    def __init__(self) -> None:
        self.rows: list[tuple[int, int, int]] = []
        self.consts: list[float] = []

    def emit(self, op: str, a: int = -1, b: int = -1, c: float = 0.0) -> int:
        self.rows.append((_OP[op], a, b))
        self.consts.append(c)
        return len(self.rows) - 1

    def chain(self, op: str, args: list[Node]) -> int:
        """``op(op(a0, a1), a2) ...``: min, max and hypot of several arguments."""
        out = self.node(args[0])
        for arg in args[1:]:
            out = self.emit(op, out, self.node(arg))
        return out

    def node(self, node: Node) -> int:
        if isinstance(node, Const):
            return self.emit("const", c=float(node.c))
        if isinstance(node, Var):
            return self.emit("var", node.i)
        if isinstance(node, Neg):
            return self.emit("neg", self.node(node.a))
        if isinstance(node, Sum):
            out = None
            for term, minus in node.terms:
                r = self.node(term)
                if out is None:
                    out = self.emit("neg", r) if minus else r
                else:
                    out = self.emit("sub" if minus else "add", out, r)
            return out
        if isinstance(node, Product):
            out = self.node(node.factors[0][0])
            for factor, divide in node.factors[1:]:
                out = self.emit("div" if divide else "mul", out, self.node(factor))
            return out
        if isinstance(node, Pow):
            return self.power(node.a, node.b)
        if isinstance(node, Unary):
            return self.emit(node.name, self.node(node.a))
        if isinstance(node, Nary):
            if node.name == "pow":
                return self.power(node.args[0], node.args[1])
            if node.name == "atan2":
                return self.emit("atan2", self.node(node.args[0]), self.node(node.args[1]))
            return self.chain(node.name, node.args)
        raise TypeError(f"not an expression node: {type(node).__name__}")

    def power(self, base: Node, exponent: Node) -> int:
        a = self.node(base)
        if not is_constant(exponent):
            return self.emit("pow", a, self.node(exponent))
        # A constant exponent as point evaluation computes it.
        with np.errstate(all="ignore"):
            c = float(value(exponent, None))
        return self.emit("powc", a, c=c)


def compile_program(root: Node) -> tuple[np.ndarray, np.ndarray]:
    """The program of an expression tree: ``(ops (t, 3) int32, consts (t,) float64)``."""
    asm = _Assembler()
    asm.node(root)
    return np.array(asm.rows, dtype=np.int32), np.array(asm.consts, dtype=np.float64)
