"""
A torus from a numpy function
=============================

The surface is the zero set of ``f``, negative inside. ``f`` receives an ``(N, 3)``
array of points and returns ``N`` values: rdmesh always calls it on large arrays,
never point by point, so write it with numpy, column by column.
"""

import numpy as np
import rdmesh


def f(p):
    """A torus of radii 1 and 0.4 about the z axis."""
    x, y, z = p.T
    return (x * x + y * y + z * z + 1 - 0.16) ** 2 - 4 * (x * x + y * y)


torus = rdmesh.ImplicitSurface(f, bounding_sphere=((0, 0, 0), 2.0))

# %%
# Mesh it: every triangle angle at least 30 degrees, every surface Delaunay ball of
# radius at most 0.04, and every facet's circumcentre within 0.01 of the surface.
# Without a gradient, rdmesh uses central differences.

mesh = rdmesh.mesh_surface(torus, angle_bound=30, radius_bound=0.04, distance_bound=0.01)
print(mesh.summary())

# %%
# The vertices lie on the surface (to the root tolerance), and the smallest angle
# meets the bound:

print(f"max |f| at the vertices: {np.abs(f(mesh.vertices)).max():.1e}")
print(f"smallest angle: {mesh.min_angle:.2f} degrees")
print(f"closed manifold: {mesh.is_closed_manifold()}, genus: {mesh.topology()['genus']}")

# %%
# A shaded picture, drawn with matplotlib (``pip install 'rdmesh[render]'``).
# ``mesh.save("torus.ply")`` would write the mesh (ply, obj, stl, off, glb, ...).

mesh.render("torus.png", title=f"torus, {len(mesh.vertices)} vertices")
