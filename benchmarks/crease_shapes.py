# SPDX-License-Identifier: GPL-3.0-or-later
"""Shapes whose creases rdmesh finds by itself (issue 28), with their exact curves.

Each :class:`CreaseShape` is an expression (what ``rdmesh.ImplicitSurface.
from_expression`` meshes with ``features="auto"``) or, for ``box_hole``, a
:func:`rdmesh.csg.difference` of two numpy callables, together with the same
function in numpy (``f``), a signed distance (``sdf``, exact or a bound near
the surface, for the surface-distance metric), the exact creases
(:mod:`feature_metrics` segments and circles),
the corners and the genus.  The same functions are in
``cgal_reference/cgal_reference.cpp`` under the same names, so that CGAL's
Mesh_3 meshes them with the curves given as polylines
(:func:`polylines`: segments as their two ends, circles as one closed
polyline of :data:`ARC_SEGMENTS` chords).

Shapes (``SHAPES``):

- ``box_rotated``: the cube ``[-1, 1]^3`` rotated by :data:`ROTATION` (off
  every axis): 12 segments, 8 corners;
- ``cylinder``: ``max(x^2 + y^2 - 1, |z| - 1)``: 2 circles;
- ``lens``: two unit balls about ``(0, 0, +-0.6)`` intersected: 1 circle of
  radius 0.8;
- ``box_dimple``: the cube minus the ball of radius 0.6 about
  ``(0, 0, 1.3)``: 12 segments, 8 corners, 1 circle on the top face;
- ``box_hole``: the cube minus the rod ``sqrt(x^2 + y^2) < 0.5`` by
  ``rdmesh.csg.difference`` (genus 1): 12 segments, 8 corners, 2 circles.
  Both operands are numpy callables, the cube the ``rdmesh.csg.intersection``
  of six half-spaces ``+-x - 1`` (each a numpy callable): a cube given as one
  callable ``max(|x|, |y|, |z|) - 1`` hides its edges inside the callable,
  and only the two circles would be found.

``box`` and ``box_ball`` of ``cad_shapes`` are found from their expressions
too (:data:`EXPRESSIONS`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from cad_shapes import box_corners, box_curves, box_sdf
from feature_metrics import Circle, Segment

__all__ = [
    "ARC_SEGMENTS",
    "EXPRESSIONS",
    "ROTATION",
    "SHAPES",
    "CreaseShape",
    "polylines",
]

#: Chords per full circle in the polylines given to CGAL (a half circle gets
#: half); the chords' sagitta for a unit circle is 1 - cos(pi / 512) = 1.9e-5.
ARC_SEGMENTS = 512

#: The rotation of ``box_rotated``: rows of the rotation by 0.6 radians about
#: (1, 2, 3) / sqrt(14), rounded to doubles (the same literals are in
#: cgal_reference.cpp; the exact curves below are those of these rows).
ROTATION = np.array(
    [
        [0.8378116424161298, -0.4277690910152775, 0.33924217987147504],
        [0.4776732010410837, 0.8752397249354845, -0.0760508836373509],
        [-0.26438601483276575, 0.22576321371476948, 0.9376198624677422],
    ]
)

#: The expressions of ``cad_shapes``' implicit cases.
EXPRESSIONS = {
    "box": "max(abs(x), abs(y), abs(z)) - 1",
    "box_ball": "min(max(abs(x), abs(y), abs(z)) - 1, "
    "sqrt((x - 1)**2 + (y - 1)**2 + (z - 1)**2) - 0.8)",
}


@dataclass
class CreaseShape:
    """A shape with creases, its exact curves and how to mesh it."""

    name: str
    expression: str | None
    f: Callable[[np.ndarray], np.ndarray]
    sdf: Callable[[np.ndarray], np.ndarray]
    curves: list
    corners: np.ndarray
    bounding_sphere: tuple
    genus: int
    description: str
    csg: Callable[[], object] | None = None  # the rdmesh surface, when not an expression


def _rows(p: np.ndarray) -> np.ndarray:
    return np.asarray(p, dtype=np.float64)


def _circle(centre, radius: float, axis: int) -> list[Circle]:
    """The circle about ``centre`` in the plane normal to ``axis``."""
    return [Circle(tuple(map(float, centre)), radius, tuple(np.eye(3)[axis]))]


def _f_box(p):
    return np.abs(_rows(p)).max(axis=1) - 1.0


def _box_rotated() -> CreaseShape:
    rows = " , ".join(
        "abs(" + " + ".join(f"({float(c)!r})*{v}" for c, v in zip(r, "xyz", strict=True)) + ")"
        for r in ROTATION
    )
    corners = np.array([np.linalg.solve(ROTATION, s) for s in box_corners()])
    index = {tuple(s): k for k, s in enumerate(box_corners())}
    curves = [
        Segment(tuple(corners[index[seg.a]]), tuple(corners[index[seg.b]])) for seg in box_curves()
    ]

    def f(p):
        return np.abs(_rows(p) @ ROTATION.T).max(axis=1) - 1.0

    def sdf(p):
        return box_sdf(_rows(p) @ ROTATION.T)

    return CreaseShape(
        "box_rotated", f"max({rows}) - 1", f, sdf, curves, corners, ((0.0, 0.0, 0.0), 2.0), 0,
        "the cube rotated by 0.6 rad about (1,2,3): 12 segments, 8 corners",
    )  # fmt: skip


def _cylinder() -> CreaseShape:
    def f(p):
        x, y, z = _rows(p).T
        return np.maximum(x * x + y * y - 1.0, np.abs(z) - 1.0)

    def sdf(p):
        x, y, z = _rows(p).T
        d = np.stack([np.hypot(x, y) - 1.0, np.abs(z) - 1.0], axis=1)
        return np.minimum(d.max(axis=1), 0.0) + np.linalg.norm(np.maximum(d, 0.0), axis=1)

    curves = _circle((0, 0, 1), 1.0, 2) + _circle((0, 0, -1), 1.0, 2)
    return CreaseShape(
        "cylinder", "max(x**2 + y**2 - 1, abs(z) - 1)", f, sdf, curves, np.zeros((0, 3)),
        ((0.0, 0.0, 0.0), 2.0), 0, "max(x^2 + y^2 - 1, |z| - 1): 2 circles",
    )  # fmt: skip


def _lens() -> CreaseShape:
    def f(p):
        q = _rows(p)
        a = np.linalg.norm(q - (0.0, 0.0, 0.6), axis=1) - 1.0
        b = np.linalg.norm(q + (0.0, 0.0, 0.6), axis=1) - 1.0
        return np.maximum(a, b)

    return CreaseShape(
        "lens",
        "max(sqrt(x**2 + y**2 + (z - 0.6)**2) - 1, sqrt(x**2 + y**2 + (z + 0.6)**2) - 1)",
        f, f, _circle((0, 0, 0), 0.8, 2), np.zeros((0, 3)), ((0.0, 0.0, 0.0), 1.5), 0,
        "two unit balls about (0,0,+-0.6) intersected: 1 circle of radius 0.8",
    )  # fmt: skip


def _box_dimple() -> CreaseShape:
    def f(p):
        q = _rows(p)
        return np.maximum(_f_box(q), 0.6 - np.linalg.norm(q - (0.0, 0.0, 1.3), axis=1))

    def sdf(p):
        q = _rows(p)
        return np.maximum(box_sdf(q), 0.6 - np.linalg.norm(q - (0.0, 0.0, 1.3), axis=1))

    return CreaseShape(
        "box_dimple",
        "max(max(abs(x), abs(y), abs(z)) - 1, 0.6 - sqrt(x**2 + y**2 + (z - 1.3)**2))",
        f, sdf, box_curves() + _circle((0, 0, 1), float(np.sqrt(0.27)), 2), box_corners(),
        ((0.0, 0.0, 0.0), 2.0), 0,
        "the cube minus the ball of radius 0.6 about (0,0,1.3): 12 segments, 1 circle",
    )  # fmt: skip


def _rod(p):
    x, y, _ = _rows(p).T
    return np.hypot(x, y) - 0.5


def _box_hole() -> CreaseShape:
    sphere = ((0.75, 0.0, 0.0), 2.5)  # centre inside the solid (CGAL shoots from it)

    def f(p):
        return np.maximum(_f_box(p), -_rod(p))

    def sdf(p):
        return np.maximum(box_sdf(_rows(p)), -_rod(p))

    def surface():
        import rdmesh

        def plane(axis: int, side: float):
            return rdmesh.ImplicitSurface(
                lambda p: side * p[:, axis] - 1.0, sphere, name=f"{side:+.0f}{'xyz'[axis]}"
            )

        faces = [plane(axis, side) for axis in range(3) for side in (1.0, -1.0)]
        box = rdmesh.csg.intersection(*faces, bounding_sphere=sphere, name="box")
        rod = rdmesh.ImplicitSurface(_rod, ((0.0, 0.0, 0.0), 3.0), name="rod")
        return rdmesh.csg.difference(box, rod, name="box_hole")

    curves = box_curves() + _circle((0, 0, 1), 0.5, 2) + _circle((0, 0, -1), 0.5, 2)
    return CreaseShape(
        "box_hole", None, f, sdf, curves, box_corners(), sphere, 1,
        "csg.difference(box, rod), the box csg.intersection of six numpy half-spaces, "
        "the rod a numpy callable (genus 1): 12 segments, 2 circles", csg=surface,
    )  # fmt: skip


#: The shapes by name, as constructors.
SHAPES: dict[str, Callable[[], CreaseShape]] = {
    "box_rotated": _box_rotated,
    "cylinder": _cylinder,
    "lens": _lens,
    "box_dimple": _box_dimple,
    "box_hole": _box_hole,
}


def polylines(curves: list) -> list[np.ndarray]:
    """The curves as CGAL polylines: a segment as its two ends, a circle as
    one closed polyline of :data:`ARC_SEGMENTS` chords, an arc as its share
    of that many."""
    out: list[np.ndarray] = []
    for c in curves:
        if isinstance(c, Segment):
            out.append(c.sample(1))
        elif isinstance(c, Circle):
            out.append(c.sample(ARC_SEGMENTS))
        else:
            out.append(c.sample(max(2, int(np.ceil(ARC_SEGMENTS * c.sweep / (2 * np.pi))))))
    return out
