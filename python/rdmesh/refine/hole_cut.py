"""Cutting the caps off the remesh of an open mesh whose holes are kept.

:class:`~rdmesh.MeshSurface` closes an open mesh's holes (caps, or the
winding number's patches) and protects their rims; the remesh of the closed
surface then has an edge chain along each rim (the feature check says whether
it does). The facets split into regions that meet only across those chains;
a region whose facets lie mostly on what closes a hole is cut off.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..surfaces._mesh_holes import RIM_SOURCE, on_caps


@dataclass
class CapCut:
    """What was cut: ``keep`` per facet, the rims, the faces and regions cut,
    the regions that lay partly on both (a rim chain missing), what closed the
    holes, and whether the rims were protected at all (``cut`` False: nothing
    could be cut)."""

    keep: np.ndarray
    rims: int
    faces_cut: int
    regions_cut: int
    mixed: int
    closed_by: str
    cut: bool = True
    trimmed: tuple[int, int] = (0, 0)

    def as_report(self) -> dict:
        return {
            "rims": self.rims,
            "faces_cut": self.faces_cut,
            "regions_cut": self.regions_cut,
            "mixed_regions": self.mixed,
            "closed_by": self.closed_by,
            "cut": self.cut,
            "slivers_trimmed": {"faces_dropped": self.trimmed[0], "faces_added": self.trimmed[1]},
        }

    def statement(self) -> str:
        """What the report says of the holes."""
        if not self.cut:
            return (
                f"The input's {self.rims} holes could not be kept (their rims were not "
                f"protected): the mesh is closed over them by the {self.closed_by}; "
                "MeshSurface(..., holes='fill') closes them smoothly instead."
            )
        s = (
            f"The input's {self.rims} holes are kept: what closed them while meshing (the "
            f"{self.closed_by}) was cut off along their protected rims ({self.faces_cut} "
            "faces)."
        )
        if any(self.trimmed):
            s += (
                f" Slivers at the rims were trimmed first ({self.trimmed[0]} input faces "
                f"dropped, {self.trimmed[1]} added)."
            )
        if self.mixed:
            s += (
                f" {self.mixed} regions lie partly on a hole's closure (a rim's edges missing "
                "from the mesh); each was kept or cut whole, by what most of it lies on."
            )
        return s


#: A region is mixed when between these shares of its facets lie on a cap.
MIXED = (0.1, 0.9)


def _closed_by(holes) -> str:
    """What closed the holes while meshing: caps, tents, the winding number's patches."""
    tents = len(np.unique(holes.apex_rim))
    caps = len(np.unique(holes.cap_rim)) - tents
    patches = len(holes.rims) - caps - tents
    used = [(k, what) for k, what in ((caps, "caps"), (tents, "tents")) if k]
    used += [(patches, "the winding number")] if patches else []
    if len(used) <= 1:
        return used[0][1].removeprefix("the ") if used else "caps"
    parts = [f"{what} ({k})" for k, what in used]
    return ", ".join(parts[:-1]) + " and " + parts[-1]


def cut_caps(surface, graph, balls, ball_ids, tri: np.ndarray, centres: np.ndarray):
    """The facets ``tri`` (sample ids) to keep, or None when ``surface`` keeps no holes.

    ``graph`` and ``balls`` are the run's feature curves and protecting balls,
    ``ball_ids`` the sample id of each ball."""
    holes = getattr(surface, "holes", None)
    if holes is None or not holes.curves:
        return None
    closed_by = _closed_by(holes)
    if balls is None or graph is None:  # the rims' protection failed
        return CapCut(np.ones(len(tri), bool), len(holes.rims), 0, 0, 0, closed_by, False,
                      holes.trimmed)  # fmt: skip
    rim_curve = np.array([c.source == RIM_SOURCE for c in graph.curves], bool)
    pairs = balls.pairs[rim_curve[balls.pair_curve]] if len(balls.pairs) else balls.pairs
    rim = ball_ids[pairs]
    n = int(max(tri.max(initial=0), rim.max(initial=0))) + 1
    rim_keys = np.sort(np.minimum(rim[:, 0], rim[:, 1]) * n + np.maximum(rim[:, 0], rim[:, 1]))
    # Facets that share an edge, unless the edge is a rim's.
    e = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    key = np.minimum(e[:, 0], e[:, 1]) * n + np.maximum(e[:, 0], e[:, 1])
    facet = np.tile(np.arange(len(tri)), 3)
    order = np.argsort(key, kind="stable")
    key, facet = key[order], facet[order]
    same = key[1:] == key[:-1]
    at = np.clip(np.searchsorted(rim_keys, key[1:]), 0, max(len(rim_keys) - 1, 0))
    on_rim = (rim_keys[at] == key[1:]) if len(rim_keys) else np.zeros(len(same), bool)
    link = same & ~on_rim
    m = len(tri)
    g = coo_matrix((np.ones(int(link.sum())), (facet[:-1][link], facet[1:][link])), shape=(m, m))
    k, region = connected_components(g, directed=False)
    on = on_caps(surface, centres)
    share = np.bincount(region, on, k) / np.maximum(np.bincount(region, minlength=k), 1)
    cut = share > 0.5
    keep = ~cut[region]
    mixed = int(np.count_nonzero((share > MIXED[0]) & (share < MIXED[1])))
    return CapCut(keep, len(holes.rims), int(np.count_nonzero(~keep)), int(cut.sum()), mixed,
                  closed_by, True, holes.trimmed)  # fmt: skip


def rim_balls(mesh, plan) -> np.ndarray | None:
    """Mesh vertex ids of the balls on the rims of kept holes only (not at a
    corner another curve ends at), or None: their angles are the input's rim's."""
    graph = plan.features
    if mesh.features is None or graph is None:
        return None
    rim = np.array([c.source == RIM_SOURCE for c in graph.curves], bool)
    if not rim.any():
        return None
    ids = np.concatenate([c for c, r in zip(mesh.features.curves, rim, strict=True) if r])
    shared = mesh.features.corners[graph.ended_by(~rim)]
    return np.setdiff1d(ids[ids >= 0], shared)
