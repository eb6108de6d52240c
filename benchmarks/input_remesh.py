# SPDX-License-Identifier: GPL-3.0-or-later
"""Triangle meshes to remesh as suite rows: rdmesh.MeshSurface against pymeshlab.

Cases: the marching-cubes mesh of a built-in surface (sphere, torus, double
torus), and its decimated and noisy versions, as ``benchmarks/remesh.py``
makes them (``remesh.variants``).  A target vertex count sets the grid of
the marching cubes (about that many vertices in the plain input, a grid of
at least 48 per axis, as ``remesh.py``'s default) and the remeshers' sizes:

- ``input``: the input mesh itself, measured the same way (not a mesher:
  time 0, no peak memory);
- ``rdmesh``: ``mesh_surface(MeshSurface(input), angle_bound=30,
  radius_bound=r, distance_bound=r / 10)`` with ``r = sqrt(0.7 area /
  size)`` (``remesh.run_rdmesh``);
- ``pymeshlab``: MeshLab's isotropic explicit remeshing, 10 iterations, the
  target edge length of an equilateral mesh with ``size`` vertices,
  ``sqrt(2 area / (sqrt(3) size))``, and the surface distance check at
  ``r / 10`` (``remesh.run_pymeshlab``, default feature angle 30°), if
  pymeshlab imports;
- ``pygalmesh``: ``pygalmesh.remesh_surface`` with the same bounds
  (``remesh.run_pygalmesh``), if pygalmesh imports.

Quality: the suite's fields, with the Hausdorff distance to the input mesh:
exact point-to-mesh distances both ways (CGAL's AABB tree through
``MeshSurface.closest_points``) from area-weighted samples plus the vertices
(``remesh.samples``); topology against the built-in surface's.
"""

from __future__ import annotations

import math
from functools import cache, lru_cache
from typing import Any

import numpy as np
import remesh
from inputs import VERTICES_PER_AREA, InputKind, quality_entry
from meshfile import mesh_run

__all__ = ["INPUT", "RemeshInput", "input_mesh"]

#: The smallest marching-cubes grid (remesh.py's default).
MIN_GRID = 48
_MC_DENSITY = 1.5


def _case(name: str) -> tuple[str, str]:
    """(built-in surface, variant) of a case name such as "torus mesh, noisy"."""
    surface, _, variant = name.partition(" mesh")
    return surface, variant.lstrip(", ") or "plain"


@lru_cache(maxsize=4)
def input_mesh(case: str, grid: int) -> tuple[np.ndarray, np.ndarray]:
    """The input of ``case`` made on a ``grid``-per-axis marching-cubes grid: (V, F)."""
    surface, variant = _case(case)
    return dict(remesh.variants(surface, grid))[variant]


@cache
def _area(surface: str) -> float:
    from metrics import mesh_area

    return mesh_area(*remesh.mc_input(surface, MIN_GRID))


class RemeshInput(InputKind):
    """Marching-cubes meshes (plain, decimated, noisy): rdmesh against MeshLab."""

    name = "remesh"
    meshers = ("input", "rdmesh", "pymeshlab", "pygalmesh")
    labels = {
        "input": "the input",
        "rdmesh": "rdmesh (MeshSurface)",
        "pymeshlab": "pymeshlab isotropic",
        "pygalmesh": "pygalmesh remesh_surface",
    }

    def cases(self) -> tuple[str, ...]:
        return tuple(
            f"{s} mesh" + ("" if v == "plain" else f", {v}")
            for s in remesh.DEFAULT_SURFACES
            for v in remesh.VARIANTS
        )

    def check(self, mesher: str) -> str | None:
        if mesher in ("pymeshlab", "pygalmesh"):
            return remesh.available(mesher)
        return None

    def params(self, case: str, size: int) -> dict[str, Any]:
        from rdmesh.surfaces import SURFACES

        surface, _ = _case(case)
        area = _area(surface)
        s = SURFACES[surface].make()
        h = math.sqrt(_MC_DENSITY * area / size)
        grid = max(MIN_GRID, round(2 * float(s.radius) / h) + 1)
        r = math.sqrt(VERTICES_PER_AREA * area / size)
        edge = math.sqrt(2 * area / (math.sqrt(3) * size))
        return {"grid": grid, "radius": r, "distance": r / 10, "edge": edge}

    def run(self, mesher: str, spec: dict) -> dict[str, Any]:
        import rdmesh
        from meshers import _maxrss_mb

        v, f = input_mesh(spec["case"], spec["grid"])
        if mesher == "pymeshlab":
            import pymeshlab  # noqa: F401  (imported before the clock starts)
        base = _maxrss_mb()
        extra: dict[str, Any] = {"input_vertices": int(len(v))}
        evaluations = 0
        if mesher == "input":
            ov, of, seconds = v, f, 0.0
            extra["not_a_mesher"] = True
        elif mesher == "rdmesh":
            ms = rdmesh.MeshSurface((v, f))
            ov, of, seconds = remesh.run_rdmesh(ms, spec["radius"], spec["distance"])
            evaluations = ms.evaluations
        elif mesher == "pymeshlab":
            ov, of, seconds = remesh.run_pymeshlab(v, f, spec["edge"], spec["distance"])
        else:
            ov, of, seconds = remesh.run_pygalmesh(
                v, f, spec["edge"], spec["radius"], spec["distance"]
            )
        out = mesh_run(
            spec.get("out"),
            ov,
            of,
            seconds=seconds,
            evaluations=evaluations,
            baseline_rss_mb=base,
            extra=extra,
        )
        if mesher == "input":
            out["peak_rss_mb"] = None
        return out

    def quality(
        self,
        case: str,
        params: dict,
        vertices,
        faces,
        *,
        reference_samples: int,
        seed: int,
        angle: float,
    ) -> dict[str, Any]:
        from rdmesh.surfaces import SURFACES

        iv, jf = input_mesh(case, params["grid"])
        h = _hausdorff_to_input(iv, jf, vertices, faces, reference_samples, seed)
        info = SURFACES[_case(case)[0]]
        expected = {"expected_components": info.components, "expected_euler": info.euler}
        return quality_entry(vertices, faces, h, angle, expected)


def _distances(mesh: tuple[np.ndarray, np.ndarray], points: np.ndarray) -> np.ndarray:
    """Exact distance from each point to the triangle mesh (CGAL's AABB tree)."""
    import rdmesh

    closest, _ = rdmesh.MeshSurface(mesh).closest_points(points)
    return np.linalg.norm(points - closest, axis=1)


def _hausdorff_to_input(iv, jf, v, f, n: int, seed: int) -> dict[str, Any] | None:
    """Two-sided sampled Hausdorff distance between a mesh and the input mesh,
    in the format of ``metrics.hausdorff``."""
    if len(f) == 0:
        return None
    on_mesh = remesh.samples(v, f, n, seed)  # n random points, then the vertices
    on_input = remesh.samples(iv, jf, n, seed + 1)
    d_ms = _distances((iv, jf), on_mesh)
    d_sm = _distances((v, f), on_input)

    def summary(d):
        return {
            "max": float(d.max()),
            "mean": float(d.mean()),
            "rms": float(np.sqrt(np.mean(d * d))),
        }

    return {
        "mesh_to_surface": summary(d_ms),
        "vertex_to_surface_max": float(d_ms[n:].max()),
        "surface_to_mesh": summary(d_sm),
        "two_sided": float(max(d_ms.max(), d_sm.max())),
        "mesh_samples": int(len(on_mesh)),
        "surface_samples": int(len(on_input)),
    }


INPUT = RemeshInput()
