"""The options of ``mesh_volume_blocks``: checked, with their defaults, before anything runs."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._validate import choice
from ..refine.criteria import FacetCriteria
from .layout import Layout

VOLUME_OPTIONS = ("spacing", "origin", "isovalue", "inside", "interpolation", "border", "name")
#: mesh_surface options passed to every block.
MESH_OPTIONS = (
    "angle_bound", "radius_bound", "distance_bound", "edge_size", "seed", "seed_resolution",
    "max_vertices", "time_limit", "method", "topology", "certify",
)  # fmt: skip
#: The face grid's spacing: at most this fraction of the edge size ...
TRACE_FRACTION = 0.25
#: ... and of the smallest sample spacing.
TRACE_SAMPLES = 0.5
#: Smallest block, in cells.
MIN_BLOCK = 8


def parse_options(options: dict) -> tuple[dict, dict]:
    """The volume's options (checked, with defaults) and the blocks' mesh_surface options."""
    for k in options:
        if k == "features":
            raise ValueError(
                "features= is not available in blocks: the blocks' balls are the seams' "
                "(mesh the volume with VolumeSurface to keep given curves)"
            )
        if k not in VOLUME_OPTIONS and k not in MESH_OPTIONS:
            raise ValueError(
                f"unknown option {k!r}; volume options: {', '.join(VOLUME_OPTIONS)}; mesh "
                f"options: {', '.join(MESH_OPTIONS)}"
            )
    vol = {
        "spacing": three("spacing", options.get("spacing", (1.0, 1.0, 1.0)), True),
        "origin": three("origin", options.get("origin", (0.0, 0.0, 0.0)), False),
        "isovalue": options.get("isovalue"),
        "inside": choice("inside", options.get("inside", "greater"), ("greater", "less")),
        "interpolation": choice(
            "interpolation", options.get("interpolation", "cubic"), ("cubic", "linear")
        ),
        "border": choice("border", options.get("border", "closed"), ("closed", "clipped")),
        "name": str(options.get("name", "volume")),
    }
    if vol["isovalue"] is not None:
        try:
            iso = float(vol["isovalue"])
        except (TypeError, ValueError):
            raise ValueError(f"isovalue must be a number, got {vol['isovalue']!r}") from None
        if not math.isfinite(iso):
            raise ValueError(f"isovalue must be finite, got {vol['isovalue']!r}")
        vol["isovalue"] = iso
    mesh = {k: v for k, v in options.items() if k in MESH_OPTIONS}
    method = mesh.pop("method", "boissonnat-oudot")
    if method != "boissonnat-oudot":
        raise ValueError(
            f"method {method!r} cannot mesh blocks: each block is clipped to its box, which "
            "only method='boissonnat-oudot' meshes"
        )
    if mesh.pop("certify", None):
        raise ValueError("certify=True is not available for volumes (nothing is proven)")
    topology = mesh.pop("topology", None)
    want = "manifold" if vol["border"] == "closed" else "manifold-with-boundary"
    if topology not in (None, want):
        raise ValueError(
            f"topology {topology!r} does not match border={vol['border']!r}, whose mesh is "
            f"{want!r}"
        )
    return vol, mesh


def three(name: str, value: Any, positive: bool) -> tuple[float, float, float]:
    try:
        v = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        v = np.full(0, np.nan)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or (positive and np.any(v <= 0)):
        what = "3 positive finite numbers" if positive else "3 finite numbers"
        raise ValueError(f"{name} must be {what}, one per volume axis, got {value!r}")
    return (float(v[0]), float(v[1]), float(v[2]))


def criteria_of(opts: dict, radius: float):
    """The blocks' criteria (checked) and the balls' spacing along the seams."""
    if opts.get("radius_bound") is None:
        opts["radius_bound"] = radius / 20.0
    criteria = FacetCriteria(
        opts.get("angle_bound", 30.0), opts["radius_bound"], opts.get("distance_bound")
    )
    size = opts.get("edge_size")
    if size is None:
        return criteria, criteria.sizing
    if callable(size):
        return criteria, FacetCriteria(0.0, size).sizing
    s = FacetCriteria(0.0, size).radius_bound
    return criteria, lambda x: np.full(len(x), s)


def trace_spacing(opts: dict, layout: Layout) -> float:
    """The face grids' spacing: a quarter of the edge size, at most half a sample."""
    h = TRACE_SAMPLES * min(layout.spacing)
    for k in ("edge_size", "radius_bound"):
        v = opts.get(k)
        if v is not None and not callable(v):
            return min(h, TRACE_FRACTION * float(v))
    return h


def check_border(layout: Layout, traces: list, border: str) -> None:
    """ValueError for a closed border that the isosurface reaches."""
    if border != "closed":
        return
    for tr in traces:
        if layout.is_outer(tr.face) and (tr.curves or tr.inside):
            a, p, _, _ = layout.rect(tr.face)
            side = "low" if p == 0 else "high"
            raise ValueError(
                f"the isosurface reaches the volume's {side} face along axis {a} (block face "
                f"{tr.face}): border='closed' is not available in blocks for a surface closed "
                "by the volume's box; use border='clipped' (a boundary on the box), or pad "
                "the volume with a layer of outside values (numpy.pad with a value on the "
                "outside of the isovalue)"
            )
