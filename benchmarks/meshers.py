#!/usr/bin/env python
# SPDX-License-Identifier: GPL-3.0-or-later
"""The meshers of the benchmark suite: an adapter for each, and the child side.

Parent side (the suite): ``adapters(names, args, record, log)`` returns one
adapter per mesher.  An adapter gives a case's parameters (``params``), the
command of one run (``command``), its timeout and repeats, why a size is
skipped (``skip``), and turns the finished run into the run record's fields
(``parse``: seconds, vertices, faces, evaluations, extra).  The floor
(``cgal_delaunay_floor``) is an adapter too: it times CGAL's bulk
``Delaunay_triangulation_3`` of the vertices the suite kept from the case's
rdmesh run, and writes no mesh.

Child side: ``python benchmarks/meshers.py SPEC`` runs one Python mesher
(rdmesh, pygalmesh, marching cubes) as the JSON ``SPEC`` describes, times the
meshing call alone and prints one JSON line.  The CGAL meshers are the
reference program (``cgal_runner.py``), which does the same.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from calibration import radius_for
from measure import last_line, run_measured
from meshfile import mesh_run
from record import fmt_size, jsonable

__all__ = ["CGAL_MESHERS", "FLOOR", "MESHERS", "adapters", "build_cgal", "child_main"]

MESHERS = (
    "rdmesh",
    "rdmesh_f_only",
    "rdmesh_certified",
    "cgal_surface_mesher",
    "cgal_mesh_3",
    "cgal_mesh_3_fast",
    "pygalmesh",
    "marching_cubes",
    "cgal_delaunay_floor",
)
CGAL_MESHERS = {
    "cgal_surface_mesher": "surface_mesher",
    "cgal_mesh_3": "mesh_3",
    "cgal_mesh_3_fast": "mesh_3_fast",
}
#: The floor: CGAL's bulk Delaunay_triangulation_3(begin, end) of the vertices
#: rdmesh output for the same case (not a mesher: a lower bound on the work of
#: any method that ends in a 3D Delaunay triangulation of those vertices).
FLOOR = "cgal_delaunay_floor"
#: Marching cubes gives about this many vertices per (area / spacing^2): one
#: per grid edge the surface crosses, 1.5 on average over normal directions.
MC_VERTICES_PER_CELL_AREA = 1.5
CHILD = Path(__file__).resolve()


# ---------------------------------------------------------------------------
# The child side: one mesher, one surface, one JSON line on stdout
# ---------------------------------------------------------------------------


def _maxrss_mb() -> float:
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _run_rdmesh(spec: dict, surface, **options) -> dict:
    """One timed rdmesh run of ``surface`` with the spec's criteria."""
    import rdmesh

    base = _maxrss_mb()
    t0 = time.perf_counter()
    m = rdmesh.mesh_surface(
        surface,
        angle_bound=spec["angle"],
        radius_bound=spec["radius"],
        distance_bound=spec["distance"],
        seed=spec["seed"],
        **options,
    )
    seconds = time.perf_counter() - t0
    return mesh_run(
        spec.get("out"),
        m.vertices,
        m.faces,
        seconds=seconds,
        evaluations=m.stats.get("evaluations", 0),
        baseline_rss_mb=base,
        extra={
            "rounds": m.stats.get("rounds"),
            "stats_seconds": m.stats.get("seconds"),
            "phase_seconds": m.stats.get("phase_seconds"),
            "interval_evaluations": m.stats.get("interval_evaluations"),
            "certified": bool(m.topology_certified),
            "complete": bool(m.complete),
        },
    )


def child_rdmesh(spec: dict) -> dict:
    import rdmesh

    return _run_rdmesh(spec, rdmesh.surfaces.get(spec["surface"]))


def child_rdmesh_f_only(spec: dict) -> dict:
    """rdmesh with the built-in surface's f alone, as most users write it: its
    gradient by central differences (6 more evaluations per gradient point)."""
    import rdmesh

    made = rdmesh.surfaces.get(spec["surface"])
    return _run_rdmesh(spec, rdmesh.ImplicitSurface(made.f, made.bounding_sphere))


def child_rdmesh_certified(spec: dict) -> dict:
    """rdmesh in certify mode: the surface as an expression, the topological-ball
    method with the same criteria, every test proven by interval arithmetic."""
    import rdmesh
    from rdmesh.surfaces.builtin import BUILTIN_EXPRESSIONS

    made = rdmesh.surfaces.get(spec["surface"])
    s = rdmesh.ImplicitSurface.from_expression(
        BUILTIN_EXPRESSIONS[spec["surface"]], made.bounding_sphere
    )
    return _run_rdmesh(spec, s, method="topological-ball", certify=True)


def child_pygalmesh(spec: dict) -> dict:
    import numpy as np
    import pygalmesh
    import rdmesh.surfaces

    f = rdmesh.surfaces.get(spec["surface"]).f
    centre = np.asarray(spec["centre"], float)
    R = float(spec["sphere_radius"])

    class Domain(pygalmesh.DomainBase):
        # pygalmesh meshes inside a sphere about the origin: translate so the
        # CGAL reference's centre (inside the surface) is the origin.
        def __init__(self):
            super().__init__()
            self.evaluations = 0

        def eval(self, x):
            self.evaluations += 1
            return float(f(np.array([x]) + centre)[0])

        def get_bounding_sphere_squared_radius(self):
            return R * R

    domain = Domain()
    base = _maxrss_mb()
    t0 = time.perf_counter()
    mesh = pygalmesh.generate_surface_mesh(
        domain,
        bounding_sphere_radius=R,
        min_facet_angle=spec["angle"],
        max_radius_surface_delaunay_ball=spec["radius"],
        max_facet_distance=spec["distance"],
        verbose=False,
        seed=spec["seed"],
    )
    seconds = time.perf_counter() - t0
    faces = np.asarray(mesh.get_cells_type("triangle"), np.int64)
    vertices = np.asarray(mesh.points, float) + centre
    return mesh_run(
        spec.get("out"),
        vertices,
        faces,
        seconds=seconds,
        evaluations=domain.evaluations,
        baseline_rss_mb=base,
        extra={"pygalmesh_version": getattr(pygalmesh, "__version__", None)},
    )


def child_marching_cubes(spec: dict) -> dict:
    import numpy as np
    import rdmesh.surfaces
    import skimage.measure  # noqa: F401  (imported before the clock starts)
    from metrics import marching_cubes_mesh

    s = rdmesh.surfaces.get(spec["surface"])
    base = _maxrss_mb()
    t0 = time.perf_counter()
    v, f, n = marching_cubes_mesh(s, np.array(spec["lo"]), np.array(spec["hi"]), spec["spacing"])
    seconds = time.perf_counter() - t0
    return mesh_run(
        spec.get("out"),
        v,
        f,
        seconds=seconds,
        evaluations=n,
        baseline_rss_mb=base,
        extra={"grid_points": int(n)},
    )


CHILDREN: dict[str, Callable[[dict], dict]] = {
    "rdmesh": child_rdmesh,
    "rdmesh_certified": child_rdmesh_certified,
    "rdmesh_f_only": child_rdmesh_f_only,
    "pygalmesh": child_pygalmesh,
    "marching_cubes": child_marching_cubes,
}


def child_main(spec: dict) -> int:
    """Run one mesher as described by ``spec``; print one JSON line.

    A spec with an ``input`` (a volume, a mesh to remesh, a clipped surface)
    goes to that input's runner (``inputs.child_run``).
    """
    if spec.get("input", "implicit") != "implicit":
        from inputs import child_run

        return child_run(spec)
    result = CHILDREN[spec["mesher"]](spec)
    print(json.dumps(jsonable(result)))
    return 0


# ---------------------------------------------------------------------------
# The parent side: one adapter per mesher
# ---------------------------------------------------------------------------


class Mesher:
    """What every adapter shares: radius bound = distance bound = r, no limits."""

    suffix = ".npz"  # the mesh file a run writes
    writes_mesh = True  # False: no surface, no quality entry

    def __init__(self, name: str) -> None:
        self.name = name

    def check(self, args: argparse.Namespace, versions: dict) -> str | None:
        """Why the mesher cannot run here (None: it can); may record its version."""
        return None

    def params(self, surface: str, size: int, cal: dict) -> dict[str, Any]:
        """The case's ``params``: what the mesher gets for this surface and size."""
        r = radius_for(cal, size)
        return {"radius": r, "distance": r}

    def skip(self, size: int, args: argparse.Namespace) -> str | None:
        """Why this size is not run (None: it is)."""
        return None

    def repeats(self, args: argparse.Namespace) -> int:
        return args.repeats

    def timeout(self, args: argparse.Namespace) -> float:
        return args.timeout

    def command(self, case: dict, args: argparse.Namespace, mesh_path: str | None) -> list[str]:
        """The command of one run; it writes the mesh to ``mesh_path`` unless None."""
        raise NotImplementedError

    def parse(self, res: dict, what: str, versions: dict) -> dict[str, Any]:
        """The run's fields, from what ``run_measured`` returned.

        Raises RuntimeError or ValueError if the run failed.
        """
        raise NotImplementedError


class PythonMesher(Mesher):
    """A mesher run by :func:`child_main` in a fresh interpreter (rdmesh as it is)."""

    def python(self, args: argparse.Namespace) -> str:
        return sys.executable

    def command(self, case: dict, args: argparse.Namespace, mesh_path: str | None) -> list[str]:
        spec = {"mesher": self.name, "surface": case["surface"], "out": mesh_path}
        spec.update(case["params"], angle=args.angle, seed=args.seed)
        return [self.python(args), str(CHILD), json.dumps(spec)]

    def parse(self, res: dict, what: str, versions: dict) -> dict[str, Any]:
        if res["returncode"] != 0:
            raise RuntimeError(
                f"exit {res['returncode']}: {last_line(res['stderr']) or 'no message'}"
            )
        return json.loads(last_line(res["stdout"]))


class Certified(PythonMesher):
    """rdmesh in certify mode, up to ``--certified-max-size``."""

    def skip(self, size: int, args: argparse.Namespace) -> str | None:
        limit = getattr(args, "certified_max_size", None)
        if limit is not None and size > limit:
            return f"above --certified-max-size {fmt_size(limit)}"
        return None


class Pygalmesh(PythonMesher):
    """pygalmesh, in ``--pygalmesh-python``, with its own size limit, repeats and timeout."""

    def check(self, args: argparse.Namespace, versions: dict) -> str | None:
        probe = run_measured(
            [
                args.pygalmesh_python,
                "-c",
                "import pygalmesh, rdmesh.surfaces; print(pygalmesh.__version__)",
            ],
            timeout=300,
        )
        if probe["returncode"] == 0:
            versions["pygalmesh"] = probe["stdout"].strip()
            return None
        return (
            f"pygalmesh is not importable by {args.pygalmesh_python} "
            f"({last_line(probe['stderr']) or 'timed out'}); "
            "install it with `pip install pygalmesh` (builds against CGAL and "
            "Eigen) or pass --pygalmesh-python"
        )

    def params(self, surface: str, size: int, cal: dict) -> dict[str, Any]:
        from cgal_runner import BOUNDING_SPHERES

        centre, R = BOUNDING_SPHERES[surface]
        return {**super().params(surface, size, cal), "centre": list(centre), "sphere_radius": R}

    def skip(self, size: int, args: argparse.Namespace) -> str | None:
        if size > args.pygalmesh_max_size:
            return f"above --pygalmesh-max-size {fmt_size(args.pygalmesh_max_size)}"
        return None

    def repeats(self, args: argparse.Namespace) -> int:
        return args.pygalmesh_repeats

    def timeout(self, args: argparse.Namespace) -> float:
        return args.pygalmesh_timeout or args.timeout

    def python(self, args: argparse.Namespace) -> str:
        return args.pygalmesh_python


class MarchingCubes(PythonMesher):
    """scikit-image's marching cubes on a grid whose spacing gives about ``size`` vertices."""

    def check(self, args: argparse.Namespace, versions: dict) -> str | None:
        try:
            import skimage  # noqa: F401
        except ImportError as exc:
            return f"scikit-image is not installed ({exc})"
        return None

    def params(self, surface: str, size: int, cal: dict) -> dict[str, Any]:
        spacing = math.sqrt(MC_VERTICES_PER_CELL_AREA * cal["area"] / size)
        return {"spacing": spacing, "lo": cal["bbox"][0], "hi": cal["bbox"][1]}


class Cgal(Mesher):
    """A CGAL mesher: the reference program (``cgal_reference/``), built once."""

    suffix = ".off"
    #: The fields of the program's JSON line kept in the run's ``extra``.
    extra_keys: tuple[str, ...] = (
        "error_bound",
        "bounding_sphere",
        "closed",
        "components",
        "euler_characteristic",
    )

    def __init__(self, name: str, exe: Path | None) -> None:
        super().__init__(name)
        self.exe = exe

    def reference_mode(self) -> str:
        """The reference program's ``--mesher``."""
        return CGAL_MESHERS[self.name]

    def reference_surface(self, case: dict) -> str:
        """The reference program's ``--surface`` for ``case``."""
        return case["surface"]

    def command(self, case: dict, args: argparse.Namespace, mesh_path: str | None) -> list[str]:
        from cgal_runner import reference_command

        p = case["params"]
        return reference_command(
            self.exe,
            self.reference_mode(),
            self.reference_surface(case),
            args.angle,
            p["radius"],
            p["distance"],
            args.cgal_error_bound,
            seed=args.seed,
            out=mesh_path,
        )

    def parse(self, res: dict, what: str, versions: dict) -> dict[str, Any]:
        from cgal_runner import parse_reference_output

        out = parse_reference_output(res["returncode"], res["stdout"], res["stderr"], what)
        versions["cgal"] = out.get("cgal_version")
        return {
            "seconds": out["seconds"],
            "vertices": out["vertices"],
            "faces": out["faces"],
            "evaluations": out["evaluations"],
            "extra": {k: out.get(k) for k in self.extra_keys},
        }


class DelaunayFloor(Mesher):
    """The floor: CGAL's bulk Delaunay build of rdmesh's vertices of the same case.

    The suite writes the vertices of the case's first successful rdmesh run to
    ``points_file`` (see ``runner.Suite``); the reference program times
    ``Delaunay_triangulation_3(begin, end)`` of them.
    """

    writes_mesh = False

    def __init__(self, name: str, exe: Path | None) -> None:
        super().__init__(name)
        self.exe = exe

    def check(self, args: argparse.Namespace, versions: dict) -> str | None:
        if "rdmesh" not in args.meshers:
            return "the floor triangulates rdmesh's vertices: add rdmesh to --meshers"
        return None

    def params(self, surface: str, size: int, cal: dict) -> dict[str, Any]:
        return {"points_of": "rdmesh"}

    def command(self, case: dict, args: argparse.Namespace, mesh_path: str | None) -> list[str]:
        from cgal_runner import delaunay_command

        points = case.get("points_file")
        if not points or not Path(points).exists():
            raise ValueError(
                f"no rdmesh vertices for {case['surface']} at {fmt_size(case['size'])} "
                "(the floor needs a successful rdmesh run of the same case first)"
            )
        return delaunay_command(self.exe, points)

    def parse(self, res: dict, what: str, versions: dict) -> dict[str, Any]:
        from cgal_runner import parse_reference_output

        out = parse_reference_output(res["returncode"], res["stdout"], res["stderr"], what)
        versions["cgal"] = out.get("cgal_version")
        return {
            "seconds": out["seconds"],
            "vertices": out["vertices"],
            "faces": 0,
            "evaluations": 0,
            "extra": {"points": out.get("points"), "cells": out.get("cells")},
        }


def build_cgal(record: dict, log: Callable[[str], None]) -> tuple[Path | None, str | None]:
    """Build the CGAL reference (once: later calls find it up to date).

    Returns (executable, None) or (None, why not); records
    ``cgal_build_seconds``.
    """
    from cgal_runner import CgalReferenceError, build_reference

    try:
        log("building the CGAL reference (first time: about a minute) ...")
        t0 = time.perf_counter()
        exe = build_reference()
        record["cgal_build_seconds"] = record.get("cgal_build_seconds", 0.0) + (
            time.perf_counter() - t0
        )
        return exe, None
    except (CgalReferenceError, OSError) as exc:
        return None, f"CGAL reference not built: {last_line(str(exc))}"


def adapters(
    names: list[str], args: argparse.Namespace, record: dict, log: Callable[[str], None]
) -> dict[str, Mesher]:
    """An adapter for each mesher in ``names``, and which of them can run.

    Those that cannot go to ``record["unavailable"]`` with the reason (a CGAL
    build failure marks every requested CGAL mesher and the floor).  Also records
    ``cgal_build_seconds`` and the pygalmesh version.
    """
    unavailable = record["unavailable"]
    kinds = {
        "rdmesh": PythonMesher,
        "rdmesh_f_only": PythonMesher,
        "rdmesh_certified": Certified,
        "pygalmesh": Pygalmesh,
        "marching_cubes": MarchingCubes,
    }
    out: dict[str, Mesher] = {m: kinds[m](m) for m in names if m in kinds}
    if any(m in CGAL_MESHERS or m == FLOOR for m in names):
        exe, why = build_cgal(record, log)
        for m in (*CGAL_MESHERS, FLOOR):
            if why is not None and m in names:
                unavailable[m] = why
            if m in names:
                out[m] = DelaunayFloor(m, exe) if m == FLOOR else Cgal(m, exe)
    for m in MESHERS:
        if (m in kinds or m == FLOOR) and m in names and m not in unavailable:
            why = out[m].check(args, record["versions"])
            if why is not None:
                unavailable[m] = why
    for m, why in unavailable.items():
        log(f"note: {m} skipped: {why}")
    return out


if __name__ == "__main__":
    sys.exit(child_main(json.loads(sys.argv[1])))
