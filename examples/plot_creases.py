"""
Creases and corners
===================

A box is not smooth: its 12 edges are creases. Restricted Delaunay refinement
alone cuts each of them with a chamfer. Given the edges as polylines
(``features=``), rdmesh covers them with protecting balls, as CGAL's Mesh_3
does, and the mesh keeps every edge and corner; ``mesh.features`` says so,
from an exact check of the output. A triangle mesh's sharp edges are found
and kept the same way (``MeshSurface(feature_angle=...)``), here for an
L-shaped bracket.
"""

import numpy as np
import rdmesh

corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
edges = [
    np.array([a, b])
    for i, a in enumerate(corners)
    for b in corners[i + 1 :]
    if np.sum(a != b) == 1
]


def box(p):
    x, y, z = np.abs(p).T
    return np.maximum(np.maximum(x, y), z) - 1


# %%
# Without features the edges come out chamfered; with them, kept.

plain = rdmesh.mesh_surface(
    rdmesh.ImplicitSurface(box, ((0, 0, 0), 2.0), features="none"),
    radius_bound=0.1,
    distance_bound=0.01,
)
kept = rdmesh.mesh_surface(
    rdmesh.ImplicitSurface(box, ((0, 0, 0), 2.0), features=edges),
    radius_bound=0.1,
    distance_bound=0.01,
)
for name, m in (("no features", plain), ("edges given", kept)):
    worst = np.abs(box(m.vertices[m.faces].mean(axis=1))).max()
    print(
        f"{name}: {len(m.vertices)} vertices, min angle {m.min_angle:.1f} deg, "
        f"largest |f| at a triangle's centroid {worst:.1e}"
    )
print(kept.summary())

plain.render("creases_box_plain.png", title="no features: chamfered edges")
kept.render("creases_box_kept.png", title="12 edges given: kept")

# %%
# A triangle mesh: an L-shaped bracket, extruded from its profile. Its sharp
# edges (faces' normals 60 degrees apart or more) are chained into curves and
# protected.

profile = np.array([[0, 0], [1.6, 0], [1.6, 0.5], [0.5, 0.5], [0.5, 1.4], [0, 1.4]]) - 0.7
n = len(profile)
verts = np.r_[np.c_[profile, np.full(n, -0.4)], np.c_[profile, np.full(n, 0.4)]]
# The two caps (the profile split into two rectangles) and the sides.
caps = [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]]
faces = [[a, c, b] for a, b, c in caps] + [[a + n, b + n, c + n] for a, b, c in caps]
for i in range(n):
    j = (i + 1) % n
    faces += [[i, j, j + n], [i, j + n, i + n]]
bracket = rdmesh.MeshSurface((verts, np.array(faces)))
print(f"bracket: {len(bracket.sharp_edges)} sharp edges in {len(bracket.sharp_curves)} curves")
remeshed = rdmesh.mesh_surface(bracket, radius_bound=0.06, distance_bound=0.006)
print(remeshed.summary())
remeshed.render("creases_bracket.png", title="L-bracket remeshed, sharp edges kept")
