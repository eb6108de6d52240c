"""
Creases found in expressions and CSG
====================================

An expression built with ``min``, ``max`` and ``abs`` says exactly where its
surface creases: where a node switches branch. rdmesh finds every crease and
corner there (``features="auto"``, the default for expressions), puts the
protecting balls on the exact curves and keeps them in the mesh; nothing is
given. Shapes built from Python functions get the same through
:mod:`rdmesh.csg`. Here a box joined with a ball (15 creases, 10 corners) and
a box with a round hole (genus 1), made by ``rdmesh.csg.difference`` of numpy
functions and as one expression.
"""

import numpy as np
import rdmesh

# %%
# The box joined with a ball, as one expression. ``features="none"`` meshes it
# as before: every crease chamfered.

text = "min(max(abs(x), abs(y), abs(z)) - 1, sqrt((x-1)**2 + (y-1)**2 + (z-1)**2) - 0.8)"
sphere = ((0.2, 0.2, 0.2), 2.4)
found = rdmesh.mesh_surface(
    rdmesh.ImplicitSurface.from_expression(text, sphere),
    radius_bound=0.1,
    distance_bound=0.01,
)
plain = rdmesh.mesh_surface(
    rdmesh.ImplicitSurface.from_expression(text, sphere, features="none"),
    radius_bound=0.1,
    distance_bound=0.01,
)
print(found.summary())
report = found.report["creases"]
print(
    f"{report['curves']} creases, {report['corners']} corners found in {report['seconds']:.2f} s; "
    f"unresolved places: {len(report['unresolved'])}"
)

# The arcs where the ball meets the box are exact: every mesh vertex on a
# crease is on the ball and on a box face to rounding.
on = np.unique(np.concatenate(found.features.curves))
v = found.vertices[on]
ball = np.abs(np.linalg.norm(v - 1.0, axis=1) - 0.8)
box = np.abs(np.abs(v).max(axis=1) - 1.0)
arcs = ball < 1e-9
print(f"{arcs.sum()} vertices on the arcs: largest distance to the box {box[arcs].max():.1e}")

plain.render("found_creases_plain.png", title="features='none': chamfered")
found.render("found_creases_box_ball.png", title="creases found: 15 curves, 10 corners")

# %%
# A box with a round hole from numpy functions. The cube is the intersection
# of its six half-spaces (a cube written as one numpy function would hide its
# edges inside it: only the hole's two circles would be found); the rod is one
# function. The result records its operands, and their gradients give the
# creases exactly.

cube_sphere = ((0.75, 0.0, 0.0), 2.5)
faces = [
    rdmesh.ImplicitSurface(lambda p, a=a, s=s: s * p[:, a] - 1.0, cube_sphere)
    for a in range(3)
    for s in (1.0, -1.0)
]
cube = rdmesh.csg.intersection(*faces, bounding_sphere=cube_sphere)
rod = rdmesh.ImplicitSurface(lambda p: np.hypot(p[:, 0], p[:, 1]) - 0.5, ((0, 0, 0), 3.0))
holed = rdmesh.mesh_surface(
    rdmesh.csg.difference(cube, rod), radius_bound=0.1, distance_bound=0.01
)
print(holed.summary())
holed.render("found_creases_box_hole.png", title="csg.difference: 14 creases, genus 1")

# %%
# The same holed box as one expression: its creases come with interval bounds,
# so the search also excludes every other box of space (``level``
# "intervals"; a CSG tree of numpy functions is searched from samples only).

holed_text = "max(max(abs(x), abs(y), abs(z)) - 1, 0.5 - sqrt(x**2 + y**2))"
holed_expr = rdmesh.mesh_surface(
    rdmesh.ImplicitSurface.from_expression(holed_text, cube_sphere),
    radius_bound=0.1,
    distance_bound=0.01,
)
print(holed_expr.summary())
