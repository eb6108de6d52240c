"""Expression trees as straight-line programs for the core's interval evaluator.

:func:`compile_program` turns an expression into one instruction per node
(``(op, a, b)`` rows and a constant per row; the result of row ``i`` is
register ``i``), which ``rdmesh.core.evaluate_intervals`` runs box after box
in C++ as interval dual numbers, by the rules of
:mod:`rdmesh.surfaces.intervals`. Expressions with a function the core has no
rule for (``tan``, ``atan2``, a variable exponent, ...) get ``None`` and stay
on the numpy evaluator.
"""

from __future__ import annotations

import numpy as np

from .expressions import _Const, _Nary, _Neg, _Node, _Pow, _Product, _Sum, _Unary, _Var

# Opcodes of cpp/interval_eval.hpp.
CONST, VAR, NEG, ADD, SUB, MUL, DIV, POWC = range(8)
_UNARY_OPS = {"sqrt": 8, "exp": 9, "log": 10, "abs": 11, "sin": 14, "cos": 15}
_NARY_OPS = {"min": 12, "max": 13}


class _Unsupported(Exception):
    pass


class _Assembler:
    def __init__(self) -> None:
        self.rows: list[tuple[int, int, int]] = []
        self.consts: list[float] = []

    def emit(self, op: int, a: int = -1, b: int = -1, c: float = 0.0) -> int:
        self.rows.append((op, a, b))
        self.consts.append(c)
        return len(self.rows) - 1

    def node(self, node: _Node) -> int:
        if isinstance(node, _Const):
            return self.emit(CONST, c=float(node.c))
        if isinstance(node, _Var):
            return self.emit(VAR, node.i)
        if isinstance(node, _Neg):
            return self.emit(NEG, self.node(node.a))
        if isinstance(node, _Sum):
            out = None
            for term, minus in node.terms:
                r = self.node(term)
                if out is None:
                    out = self.emit(NEG, r) if minus else r
                else:
                    out = self.emit(SUB if minus else ADD, out, r)
            return out
        if isinstance(node, _Product):
            out = self.node(node.factors[0][0])
            for factor, divide in node.factors[1:]:
                out = self.emit(DIV if divide else MUL, out, self.node(factor))
            return out
        if isinstance(node, _Pow):
            return self.power(node.a, node.b)
        if isinstance(node, _Unary) and node.name in _UNARY_OPS:
            return self.emit(_UNARY_OPS[node.name], self.node(node.a))
        if isinstance(node, _Nary):
            if node.name == "pow":
                return self.power(node.args[0], node.args[1])
            if node.name in _NARY_OPS:
                out = self.node(node.args[0])
                for arg in node.args[1:]:
                    out = self.emit(_NARY_OPS[node.name], out, self.node(arg))
                return out
        raise _Unsupported

    def power(self, base: _Node, exponent: _Node) -> int:
        from .intervals import _is_constant

        a = self.node(base)
        if not _is_constant(exponent):
            raise _Unsupported
        # The exponent as point evaluation computes it (intervals' convention).
        with np.errstate(all="ignore"):
            c = float(exponent.value(None))
        return self.emit(POWC, a, c=c)


def compile_program(root: _Node) -> tuple[np.ndarray, np.ndarray] | None:
    """The program of an expression tree: ``(ops (t, 3) int32, consts (t,) float64)``,
    or ``None`` when it uses a function the core's evaluator has no rule for."""
    asm = _Assembler()
    try:
        asm.node(root)
    except _Unsupported:
        return None
    return np.array(asm.rows, dtype=np.int32), np.array(asm.consts, dtype=np.float64)
