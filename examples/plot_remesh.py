"""
Remeshing a triangle mesh
=========================

:class:`rdmesh.MeshSurface` turns a triangle mesh into an implicit surface, its
signed distance (CGAL's AABB tree), so :func:`rdmesh.mesh_surface` remeshes it
with the same criteria as any other surface. The input here is a typical
marching-cubes mesh of a torus, full of slivers.
"""

import numpy as np
import rdmesh
from skimage import measure

# A torus sampled on a 40^3 grid over [-1.6, 1.6]^3, extracted by marching cubes.
n, lo, hi = 40, -1.6, 1.6
axis = np.linspace(lo, hi, n)
x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
values = (x * x + y * y + z * z + 1 - 0.16) ** 2 - 4 * (x * x + y * y)
step = (hi - lo) / (n - 1)
verts, faces, _, _ = measure.marching_cubes(values, 0.0, spacing=(step,) * 3)
verts += lo

# %%
# The input: ``(vertices, faces)`` (a ``trimesh.Trimesh`` works too). Its smallest
# angles are close to 0.

surface = rdmesh.MeshSurface((verts, faces))
original = rdmesh.SurfaceMesh(verts, faces.astype(np.int64), np.zeros((len(faces), 3)))
print(f"input: {len(verts)} vertices, min angle {original.min_angle:.2f} deg")

# %%
# Remesh it: every angle at least 30 degrees, surface balls of radius at most
# 0.06, every facet's circumcentre within 0.006 of the input.

mesh = rdmesh.mesh_surface(surface, angle_bound=30, radius_bound=0.06, distance_bound=0.006)
print(mesh.summary())

# %%
# Every vertex of the remesh lies on the input mesh:

print(f"max distance of a vertex to the input: {np.abs(surface(mesh.vertices)).max():.1e}")

original.render("remesh_input.png", title=f"input, min angle {original.min_angle:.1f} deg")
mesh.render("remesh_output.png", title=f"remeshed, min angle {mesh.min_angle:.1f} deg")
