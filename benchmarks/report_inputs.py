# SPDX-License-Identifier: GPL-3.0-or-later
"""Markdown of the suite's other inputs: volumes, remeshing, clipped surfaces (by
their sphere or by a box).

``tables(results)`` gives one table per input present in the record (what
``suite.py`` prints after the built-in surfaces' tables); ``sections(results,
plots)`` the report's sections, with each input's plots.  One row per case,
size and mesher: vertices, time, peak memory, angles, Hausdorff distance to
the input's reference and topology (components, Euler characteristic,
boundary loops, closed), each against the known value where there is one.
"""

from __future__ import annotations

from typing import Any

from inputs import INPUTS, kind
from report import _e, _f, _size, _status, _table

__all__ = ["TITLES", "input_names", "sections", "subset", "tables"]

TITLES = {
    "volume": "Volumes: VolumeSurface against CGAL's gray-image Mesh_3 and marching cubes",
    "remesh": "Remeshing: MeshSurface against pymeshlab and the input",
    "clipped": "Clipped surfaces: manifold-with-boundary against CGAL and marching cubes",
    "clipped_box": "Surfaces clipped to a box: against CGAL's labeled Mesh_3 and marching cubes",
}

_NOTES = {
    "volume": (
        "Volumes of known topology (`tests/volumes.py`), scaled so that marching cubes at the "
        "volume's resolution gives about the target vertex count (never below the case's "
        "smallest scale); rdmesh meshes the same volume (cubic B-spline, closed by the box) "
        "with radius bound = distance bound r = sqrt(0.7 area / size). Hausdorff: to the "
        "cubic interpolant's isosurface, also in voxels (the smallest spacing); Euler: per "
        "component, sorted, against the known list. CGAL: Mesh_3 on its gray-image domain "
        "(reference program, `mesh_3_image`), the same volume, isovalue and criteria, "
        "trilinear interpolation (CGAL's only one for gray images), values above the isovalue "
        "inside and the box closing the surface as for rdmesh; `cgal_mesh_3_image` uses "
        "make_mesh_3's own initial points, `cgal_mesh_3_image_components` first seeds every "
        "connected component of the samples above the isovalue."
    ),
    "remesh": (
        "Inputs: marching-cubes meshes of built-in surfaces (a grid giving about the target "
        "vertex count, at least 48 per axis), decimated (vertex clustering) and noisy "
        "(`remesh.variants`). rdmesh: `MeshSurface`, radius bound r = sqrt(0.7 area / size), "
        "distance bound r / 10; pymeshlab: isotropic explicit remeshing, 10 iterations, "
        "target edge sqrt(2 area / (sqrt(3) size)), surface distance r / 10. Hausdorff: to "
        "the input mesh, exact point-to-mesh distances both ways. Topology: against the "
        "built-in surface's. The input row is the input itself (no time, no memory)."
    ),
    "clipped": (
        "Surfaces that leave their bounding sphere (`tests/clipped_surfaces.py`). rdmesh: "
        '`topology="manifold-with-boundary"`; CGAL: `make_surface_mesh` with '
        "`Manifold_with_boundary_tag` (reference program, `surface_mesher_boundary`); "
        "marching cubes: the triangles with a vertex outside the ball dropped. All at radius "
        "bound = distance bound r = sqrt(0.7 area / size) (marching cubes: spacing "
        "sqrt(1.5 area / size)). Hausdorff: to the surface inside the ball. Boundary offset: "
        "the largest distance of a boundary vertex from the sphere; interior angle: the "
        "smallest angle of the triangles with no boundary vertex. The gyroid's topology is "
        "not known in closed form (no expected value)."
    ),
    "clipped_box": (
        "Surfaces clipped to an axis-aligned box (`tests/clipped_surfaces.py`, `clip_box`). "
        'rdmesh: `topology="manifold-with-boundary"`; CGAL has no clipping mesher for boxes: '
        "Mesh_3 on a labeled domain (0 outside the box, 1 where f < 0 inside it, 2 where "
        "f >= 0), facet criteria only, no `params::manifold()`, no protected curves, and only "
        "the facets between subdomains 1 and 2 kept (reference program, `mesh_3_box`; it "
        "meshes the box faces too, its time includes them); marching cubes: a grid spanning "
        "the box exactly. All at radius bound = distance bound r = sqrt(0.7 area / size) "
        "(marching cubes: spacing at most sqrt(1.5 area / size)). Hausdorff: to the surface "
        "inside the box. Boundary offset: the largest distance of a boundary vertex from the "
        "box's surface; interior angle: the smallest angle of the triangles with no boundary "
        "vertex. The gyroid's topology is not known in closed form (no expected value)."
    ),
}


def input_names(results: dict) -> list[str]:
    """The inputs other than the built-in surfaces that have cases, in suite order."""
    seen = {c.get("input", "implicit") for c in results.get("cases", [])}
    return [name for name in INPUTS[1:] if name in seen]


def subset(results: dict, name: str) -> dict[str, Any]:
    """``results`` with only the cases of input ``name``."""
    cases = [c for c in results.get("cases", []) if c.get("input", "implicit") == name]
    return {**results, "cases": cases}


def _expected(value, expected) -> str:
    return f"{value} ({'–' if expected is None else expected})"


def _not_a_mesher(c: dict) -> bool:
    return any((r.get("extra") or {}).get("not_a_mesher") for r in c.get("runs", []))


def quality_table(results: dict, name: str) -> str:
    """One row per case, size and mesher of input ``name`` (meshers that are
    not installed are left out and named below the table)."""
    volume, clipped = name == "volume", name in ("clipped", "clipped_box")
    header = ["case", "size", "mesher", "status", "vertices", "time (s)", "peak RSS (MB)",
              "min angle"]  # fmt: skip
    header += ["min angle, interior"] if clipped else []
    header += ["angles < 30°", "Hausdorff", "H / r"]
    header += ["H / voxel"] if volume else []
    header += ["components (exp.)", "Euler (exp.)"]
    header += ["boundary loops (exp.)", "boundary offset"] if clipped else ["closed"]
    header += ["topology"]
    rows = []
    missing: dict[str, str] = {}
    for c in subset(results, name)["cases"]:
        if c.get("status") == "unavailable":
            missing[c["mesher"]] = c.get("note") or "not available"
            continue
        s = c.get("summary") or {}
        q = c.get("quality") or {}
        seconds = "–" if _not_a_mesher(c) else _f(s.get("seconds"))
        row = [c["surface"], _size(c["size"]), c["mesher"], _status(c), _f(s.get("vertices")),
               seconds, _f(s.get("peak_rss_mb"))]  # fmt: skip
        if c.get("status") != "ok" or not q or "error" in q:
            if "error" in q:
                row[3] = f"metrics failed: {q['error']}"
            rows.append(row + ["–"] * (len(header) - len(row)))
            continue
        t = q.get("topology") or {}
        h = q.get("hausdorff") or {}
        two = h.get("two_sided")
        r = (c.get("params") or {}).get("radius")
        frac = q.get("frac_angles_below_30")
        row.append(_f(q.get("min_angle"), 4) + "°" if q.get("min_angle") is not None else "–")
        if clipped:
            mi = q.get("min_angle_interior")
            row.append(_f(mi, 4) + "°" if mi is not None else "–")
        row += [f"{100 * frac:.3g} %" if frac is not None else "–", _e(two),
                _f(two / r, 2) if (two is not None and r) else "–"]  # fmt: skip
        if volume:
            vox = q.get("voxel")
            row.append(_f(two / vox, 2) if (two is not None and vox) else "–")
        row.append(_expected(t.get("components"), t.get("expected_components")))
        if volume:
            row.append(_expected(sorted(t.get("euler_per_component") or []),
                                 sorted(t.get("expected_per_component") or [])))  # fmt: skip
        else:
            row.append(_expected(t.get("euler"), t.get("expected_euler")))
        if clipped:
            row += [_expected(t.get("boundary_loops"), t.get("expected_loops")),
                    _e(q.get("boundary_offset"))]  # fmt: skip
        else:
            row.append(_f(t.get("closed_manifold")))
        ok = t.get("topology_ok")
        row.append("ok" if ok else ("WRONG" if ok is False else "–"))
        rows.append(row)
    notes = "".join(f"\n\nNot run: `{m}` ({why})." for m, why in missing.items())
    return _table(header, rows) + notes


def _meshers(name: str) -> str:
    labels = kind(name).labels
    return "; ".join(f"`{m}`: {labels.get(m, m)}" for m in kind(name).meshers)


def tables(results: dict) -> str:
    """A heading and a table per input present in ``results``."""
    return "\n\n".join(
        f"### {TITLES[name]}\n\n{quality_table(results, name)}" for name in input_names(results)
    )


def sections(results: dict, plots: dict[str, str] | None = None) -> list[str]:
    """The report's sections of the other inputs.

    ``plots`` maps "<input>-<plot>" (for example "volume-time") to file names.
    """
    plots = plots or {}
    titles = {"time": "time", "memory": "peak memory", "hausdorff": "Hausdorff distance",
              "angles": "smallest angles"}  # fmt: skip
    parts = []
    for name in input_names(results):
        parts += [f"## {TITLES[name]}", _NOTES[name], f"Meshers: {_meshers(name)}.",
                  quality_table(results, name)]  # fmt: skip
        for key, title in titles.items():
            file = plots.get(f"{name}-{key}")
            if file:
                parts.append(f"![{name} {title}]({file})")
    return parts
