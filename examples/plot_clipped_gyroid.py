"""
A gyroid clipped to a cube
==========================

``clip_box`` meshes only the part of a surface inside an axis-aligned box, with
a boundary on the box faces: a gyroid lattice in a cube, without making a volume
first. The curve where the surface meets the box is traced on the faces, with a
sample wherever it crosses one of the 12 box edges, and the boundary vertices
are placed on it.
"""

import numpy as np
import rdmesh

gyroid = rdmesh.ImplicitSurface.from_expression(
    "sin(x)*cos(y) + sin(y)*cos(z) + sin(z)*cos(x)",
    ((0, 0, 0), 7.7),  # contains the box: its corners are 6.93 from the centre
    clip_box=[(-4, -4, -4), (4, 4, 4)],
)

# %%
# A surface with a clip box is meshed with ``topology="manifold-with-boundary"``
# (the default for it). Nothing is certified for a clipped surface: the topology
# below is what the mesh has, and the boundary check is made on samples.

mesh = rdmesh.mesh_surface(gyroid, radius_bound=0.2)
print(mesh.summary())
print(mesh.topology())
print("manifold with boundary:", mesh.is_manifold_with_boundary())

# %%
# Boundary vertices are placed on the box faces (their face coordinate is set to
# the face's value), so their distance to the box surface is exactly 0:

box = np.array([(-4.0, -4.0, -4.0), (4.0, 4.0, 4.0)])
gap = np.minimum(mesh.vertices - box[0], box[1] - mesh.vertices).min(axis=1)
print(f"{np.sum(gap == 0)} vertices on the box faces")
print("boundary loops match the traced curve:", mesh.report["boundary"]["loops_match"])

mesh.render("gyroid_in_a_cube.png", title=f"gyroid in [-4, 4]^3, {len(mesh.vertices)} vertices")
