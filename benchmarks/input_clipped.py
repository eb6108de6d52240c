# SPDX-License-Identifier: GPL-3.0-or-later
"""Surfaces clipped by their bounding sphere, or by a box, as suite rows.

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

The input "clipped_box" (:data:`BOX_INPUT`) has the cases clipped to an
axis-aligned box (``clip_box``, ``ClippedCase.box``): a gyroid in a cube and
a tilted plane in a box.  Its meshers:

- ``rdmesh``: as above (the box's surface, ``topology="manifold-with-boundary"``);
- ``cgal_mesh_3_box``: what a CGAL user does without a clipping mesher:
  Mesh_3 on a labeled domain (0 outside the box, 1 where f < 0 inside it,
  2 where f >= 0 inside it), facet criteria only, no ``params::manifold()``,
  the complex facets between subdomains 1 and 2 output (the reference
  program's ``mesh_3_box`` mode);
- ``marching_cubes``: f on a grid over the box exactly (the spacing shrunk on
  each axis to a whole number of cells), so the boundary lies on its faces.

Its quality: the same fields, with the Hausdorff distance to the surface
inside the box and ``boundary_offset`` the largest distance of a boundary
vertex from the box's surface.
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

__all__ = [
    "BOX_INPUT",
    "INPUT",
    "ClippedBoxInput",
    "ClippedInput",
    "box_marching_cubes",
    "box_offset",
    "clipped_marching_cubes",
]

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


def box_marching_cubes(surface, spacing: float) -> tuple[np.ndarray, np.ndarray, int]:
    """Marching cubes of ``surface`` on a grid spanning its ``clip_box`` exactly.

    Each axis gets ``ceil(side / spacing)`` cells (so at most ``spacing``
    apart) with grid planes on the box faces: the mesh's boundary lies on
    them.  Returns ``(vertices, faces, grid points evaluated)``.
    """
    from skimage.measure import marching_cubes

    box = getattr(surface, "clip_box", None)
    if box is None:
        raise ValueError(f"{surface.name!r} has no clip_box: use clipped_marching_cubes")
    if not spacing > 0:
        raise ValueError(f"spacing must be > 0, got {spacing!r}")
    lo, hi = np.asarray(box, float)
    cells = np.maximum(1, np.ceil((hi - lo) / spacing)).astype(int)
    axes = [np.linspace(a, b, n + 1) for a, b, n in zip(lo, hi, cells, strict=True)]
    vol = np.empty(tuple(cells + 1))
    yy, zz = np.meshgrid(axes[1], axes[2], indexing="ij")
    yz = np.column_stack([yy.ravel(), zz.ravel()])
    for i, x in enumerate(axes[0]):  # one x plane at a time: bounded memory
        vol[i] = np.asarray(surface.f(np.column_stack([np.full(len(yz), x), yz])), float).reshape(
            yy.shape
        )
    h = (hi - lo) / cells
    # f < 0 inside: the exterior is greater, which skimage calls "ascent".
    v, f, _, _ = marching_cubes(vol, level=0.0, spacing=tuple(h), gradient_direction="ascent")
    # Rounding of lo + i h may leave a face vertex 1 ulp outside: clip.
    v = np.clip(v.astype(np.float64) + lo, lo, hi)
    return v, f.astype(np.int64), int(vol.size)


def box_offset(points: np.ndarray, lo, hi) -> np.ndarray:
    """Each point's distance from the surface of the box ``[lo, hi]``."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    inside = np.minimum(points - lo, hi - points).min(axis=1)
    outside = np.linalg.norm(np.maximum(np.maximum(lo - points, points - hi), 0.0), axis=1)
    return np.where(inside >= 0, inside, outside)


def _domain_marching_cubes(surface, spacing: float) -> tuple[np.ndarray, np.ndarray, int]:
    """Marching cubes in the surface's domain: its clip box, else its ball."""
    if getattr(surface, "clip_box", None) is not None:
        return box_marching_cubes(surface, spacing)
    return clipped_marching_cubes(surface, spacing)


@cache
def _area(case: str) -> float:
    """The area of the case's surface inside its ball or box (a 96^3 marching cubes)."""
    from metrics import mesh_area

    c = CASES[case]
    s = c.surface()
    if c.box is None:
        v, f, _ = clipped_marching_cubes(s, 2 * float(s.radius) / 95)
    else:
        lo, hi = np.asarray(c.box, float)
        v, f, _ = box_marching_cubes(s, float(np.max(hi - lo)) / 95)
    return mesh_area(v, f)


@lru_cache(maxsize=2)
def _reference(case: str, n: int) -> np.ndarray:
    """Points on the case's surface inside its ball or box (``metrics.surface_reference``)."""
    from metrics import surface_reference

    c = CASES[case]
    s = c.surface()
    if c.box is None:
        centre, R = np.asarray(s.centre, float), float(s.radius)
        ref = surface_reference(s, n, bbox=(centre - R, centre + R))
        return ref[np.linalg.norm(ref - centre, axis=1) <= R]
    lo, hi = np.asarray(c.box, float)
    ref = surface_reference(s, n, bbox=(lo, hi))
    return ref[np.all((ref >= lo) & (ref <= hi), axis=1)]


def _boundary_offset(case: str, surface, points: np.ndarray) -> float:
    """The largest distance of ``points`` from the case's sphere or box surface."""
    box = CASES[case].box
    if box is None:
        r = np.linalg.norm(points - surface.centre, axis=1)
        return float(np.abs(r - surface.radius).max())
    return float(box_offset(points, *box).max())


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
        return tuple(name for name, c in CASES.items() if c.box is None)

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
            v, f, evaluations = _domain_marching_cubes(s, spec["spacing"])
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
                extra["boundary_offset"] = _boundary_offset(case, s, vertices[on])
            inner = ~on[faces].any(axis=1)
            if inner.any():
                extra["min_angle_interior"] = float(triangle_angles(vertices, faces[inner]).min())
        expected = {
            "expected_components": c.components,
            "expected_euler": c.euler,
            "expected_loops": c.loops,
        }
        return quality_entry(vertices, faces, h, angle, expected, **extra)


class CgalBox(CgalClipped):
    """CGAL's Mesh_3 on a labeled box domain, the facets between subdomains 1 and 2."""

    def reference_mode(self) -> str:
        return "mesh_3_box"

    # complex_facets: all facets Mesh_3 made, the box faces' included.
    extra_keys = (*Cgal.extra_keys, "box", "complex_facets")


class ClippedBoxInput(ClippedInput):
    """Surfaces clipped to a box: rdmesh, CGAL's labeled Mesh_3, marching cubes on the box."""

    name = "clipped_box"
    meshers = ("rdmesh", "cgal_mesh_3_box", "marching_cubes")
    labels = {
        "rdmesh": "rdmesh (manifold-with-boundary, clip_box)",
        "cgal_mesh_3_box": "Mesh_3, labeled box domain, facets between subdomains 1 and 2",
        "marching_cubes": "marching cubes on a grid spanning the box",
    }

    def cases(self) -> tuple[str, ...]:
        return tuple(name for name, c in CASES.items() if c.box is not None)

    def adapter(self, mesher: str, record: dict, log) -> tuple[Any, str | None]:
        if mesher != "cgal_mesh_3_box":
            return InputKind.adapter(self, mesher, record, log)
        exe, why = build_cgal(record, log)
        return CgalBox(mesher, exe), why


INPUT = ClippedInput()
BOX_INPUT = ClippedBoxInput()
