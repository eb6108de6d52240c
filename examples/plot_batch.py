"""
Meshing several surfaces
========================

:func:`rdmesh.mesh_many` meshes a list of surfaces in parallel on a Dask
cluster (here a local one of two worker processes, started and closed by the
call) and returns one result per job, in the order of the jobs. Each job is
isolated: one that fails or runs out of time is recorded, and the others go
on. This one meshes the eight built-in surfaces of :mod:`rdmesh.surfaces`,
each with a size bound of a fortieth of its bounding radius, plus two jobs
that go wrong on purpose, and prints a summary table: the topology found
against the known one. Each mesh is the one :func:`rdmesh.mesh_surface` makes
in this process. The :doc:`batch guide <../guide/batch>` has the details,
and ``rdmesh batch`` does the same from a file of jobs.
"""

import rdmesh
from rdmesh.surfaces import SURFACES


def broken(p):
    """A surface function with a bug: its job fails with the error."""
    raise KeyError("a bug in the surface function")


def make_jobs() -> list[rdmesh.Job]:
    jobs = []
    for name, info in SURFACES.items():
        surface = info.make()
        bound = surface.radius / 40
        jobs.append(rdmesh.Job(surface, name=name, radius_bound=bound, max_vertices=50_000))
    jobs.append(rdmesh.Job(rdmesh.ImplicitSurface(broken, ((0, 0, 0), 2.0)), name="broken"))
    # A budget that is too small: the job stops, with the partial mesh.
    torus = rdmesh.surfaces.torus()
    jobs.append(rdmesh.Job(torus, name="torus, 0.5 s", radius_bound=0.005, time_limit=0.5))
    return jobs


def print_table(results: list[rdmesh.JobResult]) -> None:
    """Status, vertices, the smallest angle in degrees, components and Euler
    characteristic (found / known), the time on the worker in seconds; then
    the errors."""
    header = ("surface", "status", "vertices", "min angle", "components", "Euler", "seconds")
    rows = [header]
    for result in results:
        topo, info = result.topology, SURFACES.get(result.name)
        row = [result.name, result.status, "", "", "", "", f"{result.seconds:.2f}"]
        if topo:
            row[2] = str(topo["vertices"])
            row[3] = f"{topo['min_angle']:.1f}"
            row[4] = str(topo["components"]) + (f" / {info.components}" if info else "")
            row[5] = str(sum(topo["euler"])) + (f" / {info.euler}" if info else "")
        rows.append(row)
    widths = [max(len(r[i]) for r in rows) for i in range(len(header))]
    for row in rows:
        print("  ".join(c.rjust(w) for c, w in zip(row, widths, strict=True)))
    print()
    for result in results:
        if result.error:
            print(f"{result.name}: {result.status}: {result.error}")


# %%
# The worker processes are new Python processes that import this script, as
# with :mod:`multiprocessing`: the batch runs under ``if __name__ ==
# "__main__":``. Then the table, and thumbnails of four of the meshes.

if __name__ == "__main__":
    results = rdmesh.mesh_many(make_jobs(), n_workers=2)
    print_table(results)
    meshes = {r.name: r.mesh for r in results if r.ok}
    for name in ("double_torus", "tanglecube", "two_spheres", "blob_line"):
        meshes[name].render(f"batch_{name}.png", title=name.replace("_", " "), size=400)
