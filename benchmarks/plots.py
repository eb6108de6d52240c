# SPDX-License-Identifier: GPL-3.0-or-later
"""PNG plots of a benchmark-suite result (matplotlib, headless Agg backend).

``render_all(results, out_dir, stem)`` draws, from the JSON written by
``suite.py`` alone:

- ``<stem>-time.png``: meshing time against vertices, log-log, one panel per
  surface, one line per mesher (medians);
- ``<stem>-memory.png``: peak RSS against vertices, same layout;
- ``<stem>-hausdorff.png``: sampled two-sided Hausdorff distance against
  vertices, same layout;
- ``<stem>-angles.png``: histograms of each triangle's smallest angle, one
  panel per mesher, one line per size (all surfaces together), with the
  30-degree bound marked.

``render_suite(results, out_dir, stem)`` draws those four for the built-in
surfaces and again for each other input in the record (volumes, remeshing,
clipped surfaces: ``<stem>-<input>-time.png`` and so on, a panel per case).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import NullFormatter  # noqa: E402

__all__ = ["COLORS", "render_all", "render_suite"]

#: One colour and marker per mesher, the same in every plot.
COLORS = {
    "rdmesh": ("tab:blue", "o"),
    "rdmesh_certified": ("tab:cyan", "D"),
    "cgal_surface_mesher": ("tab:orange", "s"),
    "cgal_mesh_3": ("tab:green", "^"),
    "cgal_mesh_3_fast": ("tab:olive", "<"),
    "pygalmesh": ("tab:red", "D"),
    "marching_cubes": ("tab:purple", "v"),
    "cgal_delaunay_floor": ("black", "x"),  # no surface: time and memory only
    "input": ("tab:gray", "P"),  # remeshing: the input mesh itself
    "pymeshlab": ("tab:brown", "*"),
    "cgal_mesh_3_image": ("tab:pink", "p"),  # volumes: Mesh_3 on a gray image
    "cgal_mesh_3_image_components": ("darkgreen", "h"),
    "cgal_mesh_3_box": ("tab:green", ">"),  # clipped to a box: labeled Mesh_3
}

_ANGLE_EDGES = np.linspace(0.0, 60.0, 121)


def _ok_cases(results: dict) -> list[dict]:
    return [c for c in results.get("cases", []) if c.get("status") == "ok" and c.get("summary")]


def _surfaces(results: dict) -> list[str]:
    seen = [c["surface"] for c in results.get("cases", [])]
    return list(dict.fromkeys(seen)) or list(results.get("settings", {}).get("surfaces", []))


def _meshers(results: dict) -> list[str]:
    seen = [c["mesher"] for c in results.get("cases", [])]
    return list(dict.fromkeys(seen)) or list(results.get("settings", {}).get("meshers", []))


def _grid(n: int) -> tuple[int, int]:
    cols = min(4, max(1, n))
    return math.ceil(n / cols), cols


def _panels(n: int, width: float = 3.6, height: float = 3.0):
    rows, cols = _grid(n)
    fig, axes = plt.subplots(
        rows, cols, figsize=(width * cols, height * rows), squeeze=False, layout="constrained"
    )
    flat = axes.ravel()
    for ax in flat[n:]:
        ax.set_visible(False)
    return fig, flat[:n]


def _per_surface(results: dict, value, ylabel: str, title: str, path: Path) -> Path:
    surfaces = _surfaces(results)
    meshers = _meshers(results)
    cases = _ok_cases(results)
    fig, axes = _panels(max(1, len(surfaces)))
    for ax, surface in zip(axes, surfaces or ["(no results)"], strict=False):
        drawn = False
        for m in meshers:
            pts = []
            for c in cases:
                if c["surface"] == surface and c["mesher"] == m:
                    y = value(c)
                    if y is not None and y > 0:
                        pts.append((c["summary"]["vertices"], y))
            if not pts:
                continue
            pts.sort()
            x, y = zip(*pts, strict=True)
            color, marker = COLORS.get(m, ("black", "x"))
            ax.plot(x, y, marker=marker, color=color, label=m)
            drawn = True
        ax.set_title(surface)
        ax.set_xlabel("vertices")
        ax.set_ylabel(ylabel)
        if drawn:
            ax.set_xscale("log")
            ax.set_yscale("log")
            # Minor-tick labels of short log axes overlap; keep the major ones.
            ax.xaxis.set_minor_formatter(NullFormatter())
            ax.yaxis.set_minor_formatter(NullFormatter())
            ax.grid(True, which="both", alpha=0.3)
        else:
            ax.text(0.5, 0.5, "no successful runs", ha="center", va="center",
                    transform=ax.transAxes)  # fmt: skip
    handles = {}
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(lab, h)
    if handles:
        # About two legend entries fit under each 3.6-inch panel.
        width = 2 * _grid(len(axes))[1]
        fig.legend(handles.values(), handles.keys(), loc="outside lower center",
                   ncols=min(width, len(handles)))  # fmt: skip
    fig.suptitle(title)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _time(c: dict) -> float | None:
    return c["summary"].get("seconds")


def _memory(c: dict) -> float | None:
    return c["summary"].get("peak_rss_mb")


def _hausdorff(c: dict) -> float | None:
    q = c.get("quality") or {}
    h = q.get("hausdorff") or {}
    return h.get("two_sided")


def _angles(results: dict, path: Path, label: str = "") -> Path:
    # The floor (a 3D triangulation of rdmesh's vertices) has no triangles.
    meshers = [m for m in _meshers(results) if m != "cgal_delaunay_floor"]
    cases = _ok_cases(results)
    sizes = sorted({c["size"] for c in cases})
    cmap = plt.get_cmap("viridis")
    fig, axes = _panels(max(1, len(meshers)), width=3.8)
    centres = 0.5 * (_ANGLE_EDGES[1:] + _ANGLE_EDGES[:-1])
    bound = results.get("settings", {}).get("angle", 30.0)
    for ax, m in zip(axes, meshers or ["(no results)"], strict=False):
        drawn = False
        for i, size in enumerate(sizes):
            total = np.zeros(len(centres))
            for c in cases:
                q = c.get("quality") or {}
                hist = q.get("min_angle_hist")
                if c["mesher"] == m and c["size"] == size and hist:
                    total += np.asarray(hist, float)
            if total.sum() == 0:
                continue
            color = cmap(i / max(1, len(sizes) - 1) * 0.85)
            ax.stairs(total / total.sum(), _ANGLE_EDGES, color=color, label=f"{size:,} target")
            drawn = True
        ax.axvline(bound, color="black", lw=0.8, ls="--")
        ax.set_title(m)
        ax.set_xlabel("smallest angle of a triangle (degrees)")
        ax.set_ylabel("fraction of triangles")
        ax.set_xlim(0, 60)
        if drawn:
            ax.legend(fontsize="small")
        else:
            ax.text(0.5, 0.5, "no quality data", ha="center", va="center",
                    transform=ax.transAxes)  # fmt: skip
    fig.suptitle(_titled(label, "Smallest-angle histograms (all cases), dashed: angle bound"))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _titled(label: str, title: str) -> str:
    return f"{label}: {title}" if label else title


def render_all(
    results: dict[str, Any], out_dir: str | Path, stem: str, label: str = ""
) -> dict[str, Path]:
    """Write the four PNGs of ``results``' cases into ``out_dir``; returns {name: path}.

    ``label`` starts each figure's title (for example the input's name).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return {
        "time": _per_surface(
            results, _time, "seconds (median)", _titled(label, "Meshing time against vertices"),
            out / f"{stem}-time.png",
        ),
        "memory": _per_surface(
            results, _memory, "peak RSS (MB)",
            _titled(label, "Peak memory of the meshing process"), out / f"{stem}-memory.png",
        ),
        "hausdorff": _per_surface(
            results, _hausdorff, "two-sided Hausdorff distance",
            _titled(label, "Sampled Hausdorff distance to the reference"),
            out / f"{stem}-hausdorff.png",
        ),
        "angles": _angles(results, out / f"{stem}-angles.png", label),
    }  # fmt: skip


def render_suite(results: dict[str, Any], out_dir: str | Path, stem: str) -> dict[str, Path]:
    """The plots of every input in ``results``; returns {name: path}.

    The built-in surfaces' as :func:`render_all` names them (``time`` in
    ``<stem>-time.png``, ...), each other input's as ``<input>-time`` in
    ``<stem>-<input>-time.png``, and so on.
    """
    by_input: dict[str, list] = {}
    for c in results.get("cases", []):
        by_input.setdefault(c.get("input", "implicit"), []).append(c)
    files: dict[str, Path] = {}
    if "implicit" in by_input or not by_input:
        files.update(render_all({**results, "cases": by_input.get("implicit", [])}, out_dir, stem))
    for name, cases in by_input.items():
        if name != "implicit":
            sub = {**results, "cases": cases}
            for key, path in render_all(sub, out_dir, f"{stem}-{name}", name).items():
                files[f"{name}-{key}"] = path
    return files
