"""Constructive solid geometry on implicit surfaces, with exact creases.

Each function takes :class:`~rdmesh.ImplicitSurface` objects (``f < 0``
inside) and returns one for the combined solid:

- :func:`union` (``min``), :func:`intersection` (``max``) and
  :func:`difference` (``max(a, -b)``): sharp creases where the operands meet;
- :func:`smooth_union`, :func:`smooth_intersection`, :func:`smooth_difference`:
  the operands blended over a width ``k`` (the quadratic polynomial smooth
  minimum: ``min(a, b) - h**2 k / 4`` with ``h = max(k - |a - b|, 0) / k``,
  continuous with its gradient): no crease.

The result records how it was made, so that :func:`rdmesh.mesh_surface`
finds its creases and corners exactly (:mod:`rdmesh.creases`), whatever the
operands are:

- when every operand is an expression (:meth:`ImplicitSurface.from_expression`),
  the result is the expression of the combination, with its exact gradient and
  interval bounds (so the interval search for creases applies; a surface
  with creases found is meshed by Boissonnat-Oudot and never certified);
- otherwise the result's function is a
  :class:`~rdmesh.surfaces.pieces.PiecewiseFunction`: the tree of ``min`` and
  ``max`` over the operands, each evaluated and differentiated by itself (its
  own ``gradient``, or central differences without one). A crease point is
  then on both operands' surfaces to Newton's precision, but the search for
  creases rests on the seeding grid's samples (no interval bounds).

A plain function, without such structure, keeps its behaviour: no crease is
searched.

Examples
--------
A box with a round hole, from two numpy functions:

>>> import numpy as np
>>> import rdmesh
>>> box = rdmesh.ImplicitSurface(lambda p: np.abs(p).max(axis=1) - 1, ((0, 0, 0), 2.0))
>>> rod = rdmesh.ImplicitSurface(
...     lambda p: np.hypot(p[:, 0], p[:, 1]) - 0.4, ((0, 0, 0), 3.0))
>>> holed = rdmesh.csg.difference(box, rod)
>>> holed.radius
2.0
"""

from __future__ import annotations

import numpy as np

from ._validate import positive
from .surfaces.expressions import MAX_LENGTH, Expression
from .surfaces.ir import Const, Nary, Neg, Node, Pow, Product, Sum, Unary
from .surfaces.oracle import ImplicitSurface
from .surfaces.pieces import Opaque, PiecewiseFunction

__all__ = [
    "difference",
    "intersection",
    "smooth_difference",
    "smooth_intersection",
    "smooth_union",
    "union",
]


def union(
    *surfaces: ImplicitSurface, name: str | None = None, bounding_sphere: tuple | None = None
) -> ImplicitSurface:
    """The union of solids: ``min`` of their functions.

    Parameters
    ----------
    *surfaces : ImplicitSurface
        Two or more operands (callables or expressions), without a clip box
        or given feature curves.
    name : str, optional
        A label; by default ``"union(a, b, ...)"`` from the operands' names.
    bounding_sphere : (centre, radius), optional
        The result's sphere; by default one that contains every operand's.

    Returns
    -------
    ImplicitSurface

    Raises
    ------
    ValueError
        Fewer than two operands, or an operand that is not an
        ImplicitSurface, has a clip box or given feature curves.
    """
    ops = _operands(surfaces, "union")
    sphere = bounding_sphere or _enclosing(ops)
    return _make("min", ops, sphere, name or _name("union", ops))


def intersection(
    *surfaces: ImplicitSurface, name: str | None = None, bounding_sphere: tuple | None = None
) -> ImplicitSurface:
    """The intersection of solids: ``max`` of their functions.

    Parameters and errors as :func:`union`; the bounding sphere is by
    default the smallest operand's (the solid lies inside every operand's).
    """
    ops = _operands(surfaces, "intersection")
    sphere = bounding_sphere or _smallest(ops)
    return _make("max", ops, sphere, name or _name("intersection", ops))


def difference(
    a: ImplicitSurface,
    b: ImplicitSurface,
    *,
    name: str | None = None,
    bounding_sphere: tuple | None = None,
) -> ImplicitSurface:
    """``a`` minus ``b``: ``max(f_a, -f_b)``.

    Parameters and errors as :func:`union`, with exactly two operands; the
    bounding sphere is by default ``a``'s.
    """
    ops = _operands((a, b), "difference")
    sphere = bounding_sphere or ops[0].bounding_sphere
    return _make("difference", ops, sphere, name or _name("difference", ops))


def smooth_union(
    a: ImplicitSurface,
    b: ImplicitSurface,
    k: float,
    *,
    name: str | None = None,
    bounding_sphere: tuple | None = None,
) -> ImplicitSurface:
    """The union of two solids blended over a width ``k``: no crease.

    Parameters
    ----------
    a, b : ImplicitSurface
    k : float
        The blend's width, in units of ``f`` (of length for signed
        distances): the result equals ``min(f_a, f_b)`` where
        ``|f_a - f_b| >= k``, and lies below it by at most ``k / 4``.
    name : str, optional
    bounding_sphere : (centre, radius), optional
        By default one that contains both operands' spheres, enlarged by
        ``k`` (the blend can bulge out by ``k / 4`` for signed distances).

    Returns
    -------
    ImplicitSurface
    """
    ops = _operands((a, b), "smooth_union")
    k = positive("k", k)
    centre, radius = _enclosing(ops)
    sphere = bounding_sphere or (centre, radius + k)
    return _make(("smooth", k), ops, sphere, name or _name("smooth_union", ops))


def smooth_intersection(
    a: ImplicitSurface,
    b: ImplicitSurface,
    k: float,
    *,
    name: str | None = None,
    bounding_sphere: tuple | None = None,
) -> ImplicitSurface:
    """The intersection of two solids blended over a width ``k``
    (``-smooth_min(-f_a, -f_b)``): no crease. As :func:`smooth_union`; the
    bounding sphere is the smaller operand's."""
    ops = _operands((a, b), "smooth_intersection")
    k = positive("k", k)
    sphere = bounding_sphere or _smallest(ops)
    return _make(("smooth-", k), ops, sphere, name or _name("smooth_intersection", ops))


def smooth_difference(
    a: ImplicitSurface,
    b: ImplicitSurface,
    k: float,
    *,
    name: str | None = None,
    bounding_sphere: tuple | None = None,
) -> ImplicitSurface:
    """``a`` minus ``b`` blended over a width ``k``
    (``-smooth_min(-f_a, f_b)``): no crease. As :func:`smooth_union`; the
    bounding sphere is ``a``'s."""
    ops = _operands((a, b), "smooth_difference")
    k = positive("k", k)
    sphere = bounding_sphere or ops[0].bounding_sphere
    return _make(("smooth-diff", k), ops, sphere, name or _name("smooth_difference", ops))


def _operands(surfaces, what: str) -> list[ImplicitSurface]:
    ops = list(surfaces)
    if len(ops) < 2:
        raise ValueError(f"{what} needs at least two surfaces, got {len(ops)}")
    for i, s in enumerate(ops):
        if not isinstance(s, ImplicitSurface):
            raise ValueError(
                f"{what}: operand {i} must be an rdmesh.ImplicitSurface, got {type(s).__name__}"
            )
        if s.clip_box is not None:
            raise ValueError(
                f"{what}: operand {i} ({s.name!r}) has a clip box; clip the result instead"
            )
        if isinstance(s.features, list) and s.features:
            raise ValueError(
                f"{what}: operand {i} ({s.name!r}) has given feature curves; give them to the "
                "result (they may not survive the combination)"
            )
    return ops


def _name(what: str, ops: list[ImplicitSurface]) -> str:
    return f"{what}({', '.join(s.name for s in ops)})"


def _enclosing(ops: list[ImplicitSurface]) -> tuple[np.ndarray, float]:
    """A sphere that contains every operand's bounding sphere (grown one
    operand at a time: not the smallest for three or more)."""
    c, r = ops[0].centre, ops[0].radius
    for s in ops[1:]:
        d = float(np.linalg.norm(s.centre - c))
        if d + s.radius <= r:
            continue
        if d + r <= s.radius:
            c, r = s.centre, s.radius
            continue
        new_r = 0.5 * (d + r + s.radius)
        c = c + (s.centre - c) * ((new_r - r) / d)
        r = new_r
    return np.asarray(c, float), float(r) * (1 + 1e-12)


def _smallest(ops: list[ImplicitSurface]) -> tuple[np.ndarray, float]:
    s = min(ops, key=lambda s: s.radius)
    return s.centre, s.radius


def _make(op, ops: list[ImplicitSurface], sphere, name: str) -> ImplicitSurface:
    if all(isinstance(s.f, Expression) for s in ops):
        text = _text(op, [f"({s.f.text})" for s in ops])
        if len(text) <= MAX_LENGTH:
            return ImplicitSurface.from_expression(text, sphere, name)
    root = _tree(op, [_leaf(s) for s in ops])
    f = PiecewiseFunction(root, name)
    return ImplicitSurface(f, sphere, gradient=f.gradient, name=name)


def _leaf(s: ImplicitSurface) -> Node:
    """An operand as a tree: an expression's own, a CSG result's own, or an
    opaque leaf (its function and its gradient)."""
    if isinstance(s.f, Expression):
        return s.f._root
    if isinstance(s.f, PiecewiseFunction):
        return s.f.root
    return Opaque(s, s.grad, s.name)


def _smooth_min_text(a: str, b: str, k: float) -> str:
    k = float(k)
    return f"min({a}, {b}) - max({k!r} - abs({a} - {b}), 0)**2/(4*{k!r})"


def _text(op, args: list[str]) -> str:
    if op in ("min", "max"):
        return f"{op}({', '.join(args)})"
    a, b = args
    if op == "difference":
        return f"max({a}, -{b})"
    kind, k = op
    if kind == "smooth":
        return _smooth_min_text(a, b, k)
    if kind == "smooth-":
        return f"-({_smooth_min_text(f'-{a}', f'-{b}', k)})"
    return f"-({_smooth_min_text(f'-{a}', b, k)})"


def _smooth_min(a: Node, b: Node, k: float) -> Node:
    kk = Const(np.float64(k))
    gap = Sum([(kk, False), (Unary("abs", Sum([(a, False), (b, True)])), True)])
    h = Nary("max", [gap, Const(np.float64(0.0))])
    blend = Product([(Pow(h, Const(np.float64(2.0))), False), (Const(np.float64(4 * k)), True)])
    return Sum([(Nary("min", [a, b]), False), (blend, True)])


def _tree(op, args: list[Node]) -> Node:
    if op in ("min", "max"):
        return Nary(op, args)
    a, b = args
    if op == "difference":
        return Nary("max", [a, Neg(b)])
    kind, k = op
    if kind == "smooth":
        return _smooth_min(a, b, k)
    if kind == "smooth-":
        return Neg(_smooth_min(Neg(a), Neg(b), k))
    return Neg(_smooth_min(Neg(a), b, k))
