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
