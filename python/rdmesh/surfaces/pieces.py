"""The smooth pieces of a piecewise smooth function: its ``min``, ``max`` and ``abs`` branches.

An expression tree (:mod:`~rdmesh.surfaces.ir`) with ``min``, ``max`` or
``abs`` nodes is smooth except where such a node switches branch. A
:class:`PieceModel` numbers those *decision nodes* (``min`` and ``max`` of
several arguments become chains of two-argument nodes, in the order
:mod:`~rdmesh.surfaces.pointwise` folds them) and evaluates, at many points at
once, with forward-mode gradients:

- the value and gradient of ``f``, or of a **piece** ``F_sigma``: the function
  with some decision nodes held on a given branch (``forced``) at each point;
- for every decision node, the branch it takes (its *choice*: 0 for the first
  argument of ``min``/``max`` or for ``abs`` of a non-negative argument, 1
  otherwise), whether its value reaches ``f`` through the branches taken
  above it (*reachable*), and its **switch** ``s`` (``a - b`` for ``min(a,
  b)`` and ``max(a, b)``, ``u`` for ``abs(u)``) with its gradient: the node
  changes branch where ``s = 0``.

A point's *label* is its choices at the reachable nodes (-1 elsewhere): two
points with different labels lie on different pieces, and a crease of the
surface lies where two pieces meet (:mod:`rdmesh.creases.search`).

Leaves may also be :class:`Opaque`: a smooth function given as numpy callables
(value and gradient), as :mod:`rdmesh.csg` builds from plain functions.
:class:`PiecewiseFunction` is such a tree as a function of ``(N, 3)`` points.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from . import pointwise
from .ir import Nary, Neg, Node, Pow, Product, Sum, Unary, Var, children

#: Functions that are not piecewise smooth (a jump): refused where creases are searched.
STEPS = ("sign", "floor", "ceil")


@dataclass(eq=False)
class Opaque(Node):
    """A smooth leaf given as numpy callables: ``f`` maps ``(N, 3)`` points to
    ``(N,)`` values and ``grad`` to ``(N, 3)`` gradients."""

    f: Callable[[np.ndarray], np.ndarray]
    grad: Callable[[np.ndarray], np.ndarray]
    name: str = "function"


@dataclass
class PieceValues:
    """What :meth:`PieceModel.evaluate` computes at ``N`` points, with ``D``
    decision nodes.

    Attributes
    ----------
    value : (N,) float64
    grad : (N, 3) float64
        The piece's value and gradient (``f``'s where nothing is forced).
    choice : (N, D) int8
        The branch each node takes (forced, or its own).
    natural : (N, D) int8
        The branch each node would take on its own.
    switch : (N, D) float64
    switch_grad : (N, D, 3) float64
        Each node's switch and its gradient.
    reachable : (N, D) bool
        The node's value reaches ``f`` through the branches taken above it.
    """

    value: np.ndarray
    grad: np.ndarray
    choice: np.ndarray
    natural: np.ndarray
    switch: np.ndarray
    switch_grad: np.ndarray
    reachable: np.ndarray

    @property
    def label(self) -> np.ndarray:
        """``(N, D)`` int8: the choice at reachable nodes, -1 elsewhere."""
        return np.where(self.reachable, self.choice, np.int8(-1)).astype(np.int8)


def _operands(node: Node) -> list[Node]:
    return [] if isinstance(node, Opaque) else children(node)


def _constant(node: Node) -> bool:
    """True when the sub-tree uses no variable and no opaque leaf."""
    if isinstance(node, (Var, Opaque)):
        return False
    return all(_constant(n) for n in children(node))


def _binary(node: Node) -> Node:
    """The tree with ``min``/``max`` of several arguments as chains of two
    (``min(a, b, c)`` is ``min(min(a, b), c)``, as point evaluation folds it)."""
    kids = _operands(node)
    if not kids:
        return node
    new = [_binary(c) for c in kids]
    if isinstance(node, Nary) and node.name in ("min", "max"):
        out = new[0]
        for arg in new[1:]:
            out = Nary(node.name, [out, arg])
        return out
    # Always a new node: a sub-tree used twice (a CSG operand in a smooth
    # minimum) gets decision nodes of its own in each place.
    return _rebuild(node, new)


def _rebuild(node: Node, kids: list[Node]) -> Node:
    """A copy of ``node`` with new operands."""
    if isinstance(node, Neg):
        return Neg(kids[0])
    if isinstance(node, Unary):
        return Unary(node.name, kids[0])
    if isinstance(node, Sum):
        return Sum([(k, m) for k, (_, m) in zip(kids, node.terms, strict=True)])
    if isinstance(node, Product):
        return Product([(k, d) for k, (_, d) in zip(kids, node.factors, strict=True)])
    if isinstance(node, Pow):
        return Pow(kids[0], kids[1])
    return Nary(node.name, kids)


def _is_decision(node: Node) -> bool:
    return (isinstance(node, Nary) and node.name in ("min", "max")) or (
        isinstance(node, Unary) and node.name == "abs"
    )


class PieceModel:
    """The decision nodes of a tree and the evaluation of its pieces.

    Parameters
    ----------
    root : Node
        An expression tree, possibly with :class:`Opaque` leaves.

    Attributes
    ----------
    nodes : list of Node
        The decision nodes in pre-order (a node before the nodes below it),
        constant sub-trees left out.
    kinds : list of str
        "min", "max" or "abs", per decision node.
    above : list of list of (int, int)
        For each decision node, the ``min``/``max`` nodes above it and the
        branch (0 or 1) that leads to it.
    """

    def __init__(self, root: Node) -> None:
        self.root = _binary(root)
        self.nodes: list[Node] = []
        self.kinds: list[str] = []
        self.above: list[list[tuple[int, int]]] = []
        self._index: dict[int, int] = {}
        self._expand: set[int] = set()
        self._walk(self.root, [])

    def _walk(self, node: Node, path: list[tuple[int, int]]) -> bool:
        """Number the decision nodes below ``node``; True when the sub-tree
        has a decision node or an opaque leaf (it must be expanded)."""
        if isinstance(node, Opaque):
            self._expand.add(id(node))
            return True
        if _constant(node):
            return False
        decision = _is_decision(node)
        if decision:
            self._index[id(node)] = len(self.nodes)
            self.nodes.append(node)
            self.kinds.append(node.name)
            self.above.append(list(path))
        expand = decision
        for k, c in enumerate(children(node)):
            branch = decision and node.name != "abs"
            expand |= self._walk(c, [*path, (self._index[id(node)], k)] if branch else path)
        if expand:
            self._expand.add(id(node))
        return expand

    @property
    def size(self) -> int:
        """The number of decision nodes."""
        return len(self.nodes)

    def steps(self) -> list[str]:
        """The step functions (:data:`STEPS`) that the tree uses on
        non-constant arguments, sorted."""
        found: set[str] = set()

        def visit(node: Node) -> None:
            if isinstance(node, Unary) and node.name in STEPS and not _constant(node.a):
                found.add(node.name)
            for c in _operands(node):
                visit(c)

        visit(self.root)
        return sorted(found)

    def value(self, points: np.ndarray) -> np.ndarray:
        """``f`` at ``(N, 3)`` points, ``(N,)`` (no gradient, nothing forced)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        xyz = (p[:, 0], p[:, 1], p[:, 2])
        with np.errstate(all="ignore"):
            v = self._value(self.root, p, xyz)
        return np.array(np.broadcast_to(np.asarray(v, dtype=np.float64), (len(p),)))

    def _value(self, node: Node, p: np.ndarray, xyz):
        if id(node) not in self._expand:
            return pointwise.value(node, xyz)
        if isinstance(node, Opaque):
            return node.f(p)
        vals = [self._value(c, p, xyz) for c in children(node)]
        return pointwise.combine_value(node, vals)

    def evaluate(self, points: np.ndarray, forced: np.ndarray | None = None) -> PieceValues:
        """Values, gradients, choices and switches at ``(N, 3)`` points.

        Parameters
        ----------
        points : (N, 3) array_like
        forced : (D,) or (N, D) int array, optional
            The branch to hold each decision node on (0 or 1), or -1 to let it
            choose; None forces nothing (``f`` itself).
        """
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        n, d = len(p), self.size
        xyz = (p[:, 0], p[:, 1], p[:, 2])
        out = {
            "choice": np.zeros((n, d), np.int8),
            "natural": np.zeros((n, d), np.int8),
            "switch": np.zeros((n, d)),
            "switch_grad": np.zeros((n, d, 3)),
        }
        if forced is not None:
            forced = np.broadcast_to(np.asarray(forced, dtype=np.int8), (n, d))
        with np.errstate(all="ignore"):
            v, g = self._dual(self.root, p, xyz, forced, out)
        value = np.array(np.broadcast_to(np.asarray(v, dtype=np.float64), (n,)))
        grad = np.zeros((n, 3)) if g is None else np.array(np.broadcast_to(g, (3, n)).T)
        reach = np.ones((n, d), bool)
        for k, path in enumerate(self.above):
            for m, branch in path:
                reach[:, k] &= out["choice"][:, m] == branch
        return PieceValues(value, grad, reachable=reach, **out)

    def _dual(self, node: Node, p: np.ndarray, xyz, forced, out: dict) -> tuple:
        if id(node) not in self._expand:
            return pointwise.dual(node, xyz)
        if isinstance(node, Opaque):
            return np.asarray(node.f(p), dtype=np.float64), np.asarray(node.grad(p)).T
        duals = [self._dual(c, p, xyz, forced, out) for c in children(node)]
        if id(node) not in self._index:
            return pointwise.combine_dual(node, duals)
        k, n = self._index[id(node)], len(p)
        if node.name == "abs":
            (u, gu) = duals[0]
            natural = np.asarray(u < 0)
            s, gs = u, gu
        else:
            (a, ga), (b, gb) = duals
            natural = np.asarray(a > b if node.name == "min" else a < b)
            s = a - b
            gs = pointwise._gadd(ga, pointwise._gscale(gb, -1.0))
        natural = np.broadcast_to(natural, (n,)).astype(np.int8)
        choice = natural if forced is None else np.where(forced[:, k] >= 0, forced[:, k], natural)
        out["natural"][:, k] = natural
        out["choice"][:, k] = choice
        out["switch"][:, k] = np.broadcast_to(s, (n,))
        if gs is not None:
            out["switch_grad"][:, k] = np.broadcast_to(gs, (3, n)).T
        second = choice.astype(bool)
        if node.name == "abs":
            sign = np.where(second, -1.0, 1.0)
            return u * sign, pointwise._gscale(gu, sign)
        return np.where(second, b, a), pointwise._gwhere(second, gb, ga)


class PiecewiseFunction:
    """A function of ``(N, 3)`` points given by a tree with opaque leaves
    (what :mod:`rdmesh.csg` builds), with its exact gradient.

    Parameters
    ----------
    root : Node
        The tree (``min``, ``max``, arithmetic, and :class:`Opaque` leaves).
    text : str
        How it was made, for messages (``"union(a, b)"``).
    """

    def __init__(self, root: Node, text: str) -> None:
        self.root = root
        self.text = text
        self.model = PieceModel(root)

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Values at ``(N, 3)`` points, ``(N,)``."""
        return self.model.value(points)

    def gradient(self, points: np.ndarray) -> np.ndarray:
        """Gradients at ``(N, 3)`` points, ``(N, 3)`` (the branch taken at each
        ``min``, ``max`` and ``abs``; the first on ties)."""
        return self.model.evaluate(points).grad

    def __repr__(self) -> str:
        return f"PiecewiseFunction({self.text!r})"
