"""The report of a volume meshed in blocks: the same keys as ``mesh_surface``'s, for the whole."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..io.result import SurfaceMesh
from ..topology.complex import component_topology
from .layout import Layout
from .network import Network
from .tasks import BlockResult


def whole_report(
    mesh: SurfaceMesh,
    layout: Layout,
    results: list[BlockResult],
    seams: dict,
    net: Network,
    vol: dict,
    repairs: dict,
) -> dict[str, Any]:
    """The welded mesh's report.

    ``components``, ``euler``, ``boundary_loops`` and ``closed_manifold`` are
    those of the welded mesh; ``seams`` the exact checks of the weld
    (:func:`rdmesh.blocks.weld.seam_check`) and the network (curves, corners,
    balls, centres that did not converge onto their curve); ``blocks`` one
    entry per block; ``features`` the seams' feature check. The
    topological-ball tests are not run on the whole (``tests`` is empty and
    nothing is certified): each block's run is that of a clipped surface.
    """
    chi, loops = component_topology(mesh.faces, len(mesh.vertices))
    seams = dict(seams)
    seams.update(
        curves=len(net.graph.curves),
        corners=len(net.graph.corners),
        balls=len(net.balls),
        unprojected_centres=repairs.get("unprojected_centres", 0),
        radii_settled=repairs.get("radii_settled", 0),
        repairs=repairs.get("rounds", 0),
    )
    blocks = []
    for r in results:
        box = layout.box(r.block)
        blocks.append(
            {
                "block": list(r.block),
                "box": box.tolist(),
                "vertices": int(len(r.vertices)),
                "faces": int(len(r.faces)),
                "balls": int(r.stats.get("balls", 0)),
                "seconds": round(float(r.stats.get("seconds", 0.0)), 3),
                "complete": bool(r.complete),
                "stop_reason": r.stop_reason,
                "feature_check": r.held,
                "min_angle": r.stats.get("min_angle"),
                "peak_memory_mb": round(float(r.peak_mb), 1),
                "empty": bool(r.stats.get("empty", False)),
            }
        )
    clipped = vol["border"] == "clipped"
    return {
        **summed(results),
        "method": "boissonnat-oudot",
        "blocks_layout": {
            "counts": list(layout.counts),
            "planes": [list(p) for p in layout.planes],
        },
        "components": len(chi),
        "euler": chi,
        "boundary_loops": loops,
        "closed_manifold": mesh.is_closed_manifold(),
        "boundary": {"domain": "box", "mesh_loops": int(sum(loops))} if clipped else None,
        "seams": seams,
        "features": None if mesh.features is None else mesh.features.as_report(),
        "blocks": blocks,
        "unresolved": int(len(mesh.unresolved)),
        "tests": {},
        "tbp_holds": None,
        "certified": False,
        "statement": (
            "Each block was meshed as a surface clipped to its box, with the protecting balls "
            "of its faces; the welded mesh's topology is what the mesh has (sampled, not "
            "certified). The seam check is exact: "
            + ("it held." if seams.get("held") else "it FAILED (see seams).")
        ),
        "min_angle": float(np.min(mesh.angles)) if len(mesh.faces) else None,
    }


def summed(results: list[BlockResult]) -> dict[str, Any]:
    """``mesh_surface``'s per-run report entries over every block: the seeding
    ("proven" only if every block's was), probes and singular points counted,
    the unresolved and violation regions of every block, the first spacing floor."""
    reps = [r.report for r in results if r.report]
    levels = [(rep.get("seeding") or {}).get("level") for rep in reps]
    floors = [rep["spacing_floor"] for rep in reps if rep.get("spacing_floor") is not None]
    singular = [rep.get("singular_points") or {} for rep in reps]
    return {
        "seeding": {
            "level": "proven" if levels and all(v == "proven" for v in levels) else "sampled",
            "blocks": {str(v): levels.count(v) for v in sorted(set(map(str, levels)))},
            "basis": "each block's grid scan (a surface clipped to its box): components "
            "smaller than about two grid cells of a block can be missed",
        },
        "probes": {"count": int(sum((rep.get("probes") or {}).get("count", 0) for rep in reps))},
        "singular_points": {
            "count": int(sum(s.get("count", 0) for s in singular)),
            "regions": [g for s in singular for g in s.get("regions", [])],
        },
        "spacing_floor": floors[0] if floors else None,
        "critical_points": None,  # the topological-ball method's, which blocks do not use
        "relabelled": None,  # pinches are relabelled on closed surfaces only, not on blocks
        "pockets": None,  # volumes: their components are not known beforehand
        "unresolved_regions": [g for rep in reps for g in rep.get("unresolved_regions") or []],
        "violation_regions": [g for rep in reps for g in rep.get("violation_regions") or []],
    }
