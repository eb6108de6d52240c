"""Thin parts of a closed input mesh, and a radius bound lowered there (issue 30).

Where a closed input is thinner than the radius bound (a rod, a thin plate),
or two of its parts are closer together than it (a slit), the samples the
bound asks for cannot resolve it and the remesh loses its topology there (a
rod between two balls comes out in pieces). When that happens
(:func:`~._mesh_topology.topology_against_input`), ``mesh_surface`` meshes
again with the bound lowered near the thin parts, found so:

- the input's vertices, one per cell of :data:`PROBE_CELL` radius bounds;
- from each, rays along both of its normal's directions, and around them in a
  cone of :data:`CONE` degrees (a shape-diameter estimate: the median
  length, so that a faceted input's creases do not count as thin);
- a vertex whose median length either way is below the radius bound is thin
  there, and the bound near it becomes :data:`SHARE` of that length (at
  least the spacing floor), growing by :data:`GRADING` per unit of distance
  from it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .._regions import describe_regions, regions
from .._vectors import ring_directions, unit_rows
from ._mesh_input import area_vectors

#: Probes: one input vertex per cell of this many radius bounds.
PROBE_CELL = 0.25
#: Half-angle of the cone of rays around each probe's normal, degrees.
CONE = 20.0
#: Rays around the axis (besides the axis itself), each way.
RAYS = 6
#: The lowered bound is this share of the thickness: a rod of diameter ``t``
#: sampled at ``t / 3`` has about 5 samples around.
SHARE = 1.0 / 3.0
#: The lowered bound grows by this much per unit of distance from a thin probe.
GRADING = 0.5
#: Thin probes the sizing field looks at around each point.
NEAREST = 8
#: The lowered bound is at least this share of the radius bound ...
THIN_FLOOR = 1.0 / 32.0
#: ... and the run again is skipped (the loss of topology reported) when the
#: thin parts would ask for more than this many times the first run's vertices.
THIN_GROWTH = 10.0
#: Hits closer than this share of the ray's length are the probe's own faces.
OWN_FACE = 1e-6


@dataclass
class ThinParts:
    """Thin probes of an input and the radius bound near them."""

    points: np.ndarray  # (k, 3) thin probes
    sizes: np.ndarray  # (k,) the bound at each
    radius_bound: float

    def __post_init__(self) -> None:
        self._tree = cKDTree(self.points)

    def sizing(self, centres: np.ndarray) -> np.ndarray:
        """The lowered bound at ``(n, 3)`` centres: at most the radius bound,
        at most ``sizes + GRADING * distance`` to each nearby thin probe."""
        k = min(NEAREST, len(self.points))
        d, i = self._tree.query(centres, k=k, distance_upper_bound=self.radius_bound / GRADING)
        d, i = d.reshape(len(centres), k), i.reshape(len(centres), k)
        found = i < len(self.points)
        near = self.sizes[np.minimum(i, len(self.points) - 1)]
        size = np.where(found, near + GRADING * d, np.inf)
        return np.minimum(self.radius_bound, size.min(axis=1))

    def vertices_asked(self) -> float:
        """About how many vertices the lowered bound asks for on the probes'
        cells (about ``2 / s**2`` per unit area at bound ``s``)."""
        cell = (PROBE_CELL * self.radius_bound) ** 2
        return float(np.sum(2.0 * cell / self.sizes**2))

    def report(self, link: float) -> dict:
        """For the mesh's report: the probes found thin, the least bound, where."""
        found = regions(self.points, link)
        return {
            "probes": len(self.points),
            "least_bound": float(self.sizes.min()),
            "regions": found,
            "statement": (
                f"the radius bound was lowered near {len(self.points)} points of the input "
                f"thinner than it, or closer to another part than it, to as little as "
                f"{self.sizes.min():.3g} ({describe_regions(found)})"
            ),
        }


def thin_parts(surface, radius_bound: float, floor: float) -> ThinParts | None:
    """The thin parts of ``surface``'s input (a closed :class:`~rdmesh.MeshSurface`)
    against ``radius_bound``, with bounds at least ``floor``; None where there
    are none."""
    v, f = surface.vertices, surface.faces[: surface.input_face_count]
    normal = np.zeros_like(v)  # area-weighted vertex normals
    np.add.at(normal, f.reshape(-1), np.repeat(area_vectors(v, f), 3, axis=0))
    used = np.flatnonzero(np.linalg.norm(normal, axis=1) > 0)
    cell = np.floor(v[used] / (PROBE_CELL * radius_bound)).astype(np.int64)
    cell -= cell.min(axis=0)
    span = cell.max(axis=0) + 1
    key = (cell[:, 0] * span[1] + cell[:, 1]) * span[2] + cell[:, 2]
    _, first = np.unique(key, return_index=True)
    probe = used[np.sort(first)]
    p, n = v[probe], unit_rows(normal[probe])
    length = np.full(len(p), np.inf)
    for sign in (1.0, -1.0):
        length = np.minimum(length, _median_reach(surface, p, n, sign, radius_bound))
    thin = length < radius_bound
    if not thin.any():
        return None
    return ThinParts(p[thin], np.maximum(floor, SHARE * length[thin]), radius_bound)


def _median_reach(surface, p: np.ndarray, n: np.ndarray, sign: float, reach: float):
    """The median, over the rays in a cone about ``sign * n`` from each of ``p``,
    of the distance to the first face hit past ``p``'s own (``reach`` where none
    is hit within it)."""
    dirs = ring_directions(n, sign, (np.radians(CONE),), RAYS).transpose(1, 0, 2)
    start = p[None] + 1e-9 * reach * dirs
    seg = np.stack([start, p[None] + reach * dirs], axis=2).reshape(-1, 2, 3)
    hit, t, _ = surface._core.segment_hits(np.ascontiguousarray(seg))
    first = np.full(len(seg), 1.0)
    ok = np.isfinite(t) & (t > OWN_FACE)  # not the probe's own faces
    np.minimum.at(first, hit[ok], t[ok])
    return np.median(first.reshape(len(dirs), len(p)), axis=0) * reach
