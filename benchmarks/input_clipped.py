# SPDX-License-Identifier: GPL-3.0-or-later
"""Surfaces clipped by their bounding sphere as suite rows.

Cases: the four of ``tests/clipped_surfaces.py`` (a gyroid in a sphere of
radius 2, a plane through the unit ball, a cylinder longer than it, a torus
cut in half by it).  For a target vertex count ``size``, with ``area`` the
surface's area inside the ball (from a marching-cubes mesh):

- ``rdmesh``: ``mesh_surface(surface, topology="manifold-with-boundary",
  radius_bound=r, distance_bound=r)``, ``r = sqrt(0.7 area / size)``;
- ``cgal_surface_mesher``: CGAL's ``make_surface_mesh`` with
  ``Manifold_with_boundary_tag`` (the reference program's
  ``surface_mesher_boundary`` mode), the same criteria, error bound as the
  suite's;
- ``marching_cubes``: f on a grid over the ball's cube at spacing
  ``sqrt(1.5 area / size)``, marching cubes, and the triangles with a vertex
  outside the ball dropped (what one does without a clipping mesher).

Quality: the suite's fields, the Hausdorff distance to the surface inside
the ball (reference points on the surface, those inside the ball kept), the
boundary loops against the known number, ``boundary_offset`` (how far the
boundary vertices are from the sphere) and ``min_angle_interior`` (the
smallest angle of the triangles with no boundary vertex).
"""

from __future__ import annotations

import math
import sys
import time
from functools import cache, lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from inputs import VERTICES_PER_AREA, InputKind, quality_entry
from meshers import Cgal, build_cgal
from meshfile import mesh_run

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from clipped_surfaces import CASES  # noqa: E402

__all__ = ["INPUT", "ClippedInput", "clipped_marching_cubes"]

_MC_DENSITY = 1.5


def clipped_marching_cubes(surface, spacing: float) -> tuple[np.ndarray, np.ndarray, int]:
    """Marching cubes of ``surface`` over its sphere's cube, cut to the ball.

    Triangles with a vertex outside the bounding ball are dropped. Returns
    ``(vertices, faces, grid points evaluated)``, unused vertices dropped.
    """
    from metrics import compact, marching_cubes_mesh

    c, R = np.asarray(surface.centre, float), float(surface.radius)
    v, f, n = marching_cubes_mesh(surface, c - R, c + R, spacing)
    inside = np.linalg.norm(v - c, axis=1) <= R
    v, f = compact(v, f[inside[f].all(axis=1)])
    return v, f, n


@cache
def _area(case: str) -> float:
    """The area of the case's surface inside its ball (a 96^3 marching cubes)."""
    from metrics import mesh_area

    s = CASES[case].surface()
    v, f, _ = clipped_marching_cubes(s, 2 * float(s.radius) / 95)
    return mesh_area(v, f)


@lru_cache(maxsize=2)
def _reference(case: str, n: int) -> np.ndarray:
    """Points on the case's surface inside its ball (``metrics.surface_reference``)."""
    from metrics import surface_reference

    s = CASES[case].surface()
    c, R = np.asarray(s.centre, float), float(s.radius)
    ref = surface_reference(s, n, bbox=(c - R, c + R))
    return ref[np.linalg.norm(ref - c, axis=1) <= R]


class CgalClipped(Cgal):
    """CGAL's Surface_mesher with Manifold_with_boundary_tag on a clipped case."""

    def reference_mode(self) -> str:
        return "surface_mesher_boundary"

    def reference_surface(self, case: dict) -> str:
        return CASES[case["surface"]].cgal


class ClippedInput(InputKind):
    """Clipped surfaces: rdmesh with boundary, CGAL with boundary, clipped marching cubes."""

    name = "clipped"
    meshers = ("rdmesh", "cgal_surface_mesher", "marching_cubes")
    labels = {
        "rdmesh": "rdmesh (manifold-with-boundary)",
        "cgal_surface_mesher": "Surface_mesher (Manifold_with_boundary_tag)",
        "marching_cubes": "marching cubes, cut to the ball",
    }

    def cases(self) -> tuple[str, ...]:
        return tuple(CASES)

    def check(self, mesher: str) -> str | None:
        if mesher == "marching_cubes":
            try:
                import skimage  # noqa: F401
            except ImportError as exc:
                return f"scikit-image is not installed ({exc})"
        return None

    def adapter(self, mesher: str, record: dict, log) -> tuple[Any, str | None]:
        if mesher != "cgal_surface_mesher":
            return super().adapter(mesher, record, log)
        exe, why = build_cgal(record, log)
        return CgalClipped(mesher, exe), why

    def params(self, case: str, size: int) -> dict[str, Any]:
        area = _area(case)
        r = math.sqrt(VERTICES_PER_AREA * area / size)
        return {"radius": r, "distance": r, "spacing": math.sqrt(_MC_DENSITY * area / size)}

    def run(self, mesher: str, spec: dict) -> dict[str, Any]:
        import rdmesh
        from meshers import _maxrss_mb

        s = CASES[spec["case"]].surface()
        base = _maxrss_mb()
        if mesher == "rdmesh":
            t0 = time.perf_counter()
            m = rdmesh.mesh_surface(
                s,
                topology="manifold-with-boundary",
                angle_bound=spec["angle"],
                radius_bound=spec["radius"],
                distance_bound=spec["distance"],
                seed=spec["seed"],
            )
            seconds = time.perf_counter() - t0
            v, f = m.vertices, m.faces
            evaluations = int(m.stats.get("evaluations", 0))
            extra = {"complete": bool(m.complete)}
        else:
            import skimage.measure  # noqa: F401  (imported before the clock starts)

            t0 = time.perf_counter()
            v, f, evaluations = clipped_marching_cubes(s, spec["spacing"])
            seconds = time.perf_counter() - t0
            extra = {"grid_points": int(evaluations)}
        return mesh_run(
            spec.get("out"),
            v,
            f,
            seconds=seconds,
            evaluations=evaluations,
            baseline_rss_mb=base,
            extra=extra,
        )

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
        from metrics import hausdorff, triangle_angles
        from rdmesh.topology.complex import complex_status

        c = CASES[case]
        s = c.surface()
        h = None
        extra: dict[str, Any] = {"boundary_offset": None, "min_angle_interior": None}
        if len(faces):
            h = hausdorff(s, vertices, faces, _reference(case, reference_samples), seed=seed)
            n = len(vertices)
            st = complex_status(faces, n)
            key = st.edge_key[st.edge_count == 1]
            on = np.zeros(n, bool)
            on[key // n] = on[key % n] = True
            if on.any():
                r = np.linalg.norm(vertices[on] - s.centre, axis=1)
                extra["boundary_offset"] = float(np.abs(r - s.radius).max())
            inner = ~on[faces].any(axis=1)
            if inner.any():
                extra["min_angle_interior"] = float(triangle_angles(vertices, faces[inner]).min())
        expected = {
            "expected_components": c.components,
            "expected_euler": c.euler,
            "expected_loops": c.loops,
        }
        return quality_entry(vertices, faces, h, angle, expected, **extra)


INPUT = ClippedInput()
