"""
Meshing several surfaces
========================

Meshing several surfaces is a loop: each :func:`rdmesh.mesh_surface` call is
independent, and a failure (bad input, a budget) raises an exception that can be
recorded per surface before going on. This one meshes the eight built-in
surfaces of :mod:`rdmesh.surfaces`, each with a size bound of a fortieth of its
bounding radius, and prints a summary table: the topology found against the
known one.
"""

import time

import rdmesh
from rdmesh.surfaces import SURFACES

rows = []
meshes = {}
for name, info in SURFACES.items():
    t0 = time.perf_counter()
    try:
        surface = info.make()
        mesh = rdmesh.mesh_surface(surface, radius_bound=surface.radius / 40, max_vertices=50_000)
    except rdmesh.RdmeshError as error:  # record it and go on with the next surface
        rows.append(
            (name, "failed", type(error).__name__, "", "", f"{time.perf_counter() - t0:.2f}")
        )
        continue
    topo = mesh.topology()
    euler = sum(topo["euler"])
    ok = topo["components"] == info.components and euler == info.euler
    rows.append(
        (
            name,
            len(mesh.vertices),
            f"{mesh.min_angle:.1f}",
            f"{topo['components']} / {info.components}",
            f"{euler} / {info.euler}" + ("" if ok else "  <- differs"),
            f"{time.perf_counter() - t0:.2f}",
        )
    )
    meshes[name] = mesh

# %%
# The table: vertices, the smallest angle in degrees, components and Euler
# characteristic (found / known), and the wall time in seconds.

header = ("surface", "vertices", "min angle", "components", "Euler", "seconds")
widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
for r in [header, *rows]:
    print("  ".join(str(c).rjust(w) for c, w in zip(r, widths, strict=True)))

# %%
# Thumbnails of four of them.

for name in ("double_torus", "tanglecube", "two_spheres", "blob_line"):
    meshes[name].render(f"batch_{name}.png", title=name.replace("_", " "), size=400)
