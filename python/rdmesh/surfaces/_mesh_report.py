"""What in a :class:`~rdmesh.MeshSurface`'s input stands in the way of its topology.

:class:`MeshReport` finds where the input intersects itself (CGAL's
``self_intersections``, for closed manifold inputs) and, after a run, where two
sheets of the input are closer than refinement can separate; both go into the
mesh's report (``report["input"]``).
"""

from __future__ import annotations

import logging
from functools import cached_property

import numpy as np

from .._mesh_components import component_euler, components
from .._regions import describe_regions, regions
from .._tol import REGION_LINK
from ._mesh_topology import topology_against_input

log = logging.getLogger("rdmesh")

#: Two sheets closer than this (times R) where points were refused are reported.
CLOSE_SHEETS = 0.02
#: Probes along the normal that bracket the gap between sheets, then
#: bisections of the bracket (to 2^-20 of a probe step).
GAP_SAMPLES, GAP_BISECTIONS = 64, 20


class MeshReport:
    """Self-intersections and close sheets of a mesh, for the mesh's report.

    A base of :class:`~rdmesh.MeshSurface` (after
    :class:`~rdmesh.surfaces._mesh_queries.MeshQueries`, whose queries it uses).
    """

    def _find_self_intersections(self) -> None:
        """``self_intersections``: the pairs of faces that cross (CGAL's
        Polygon_mesh_processing::self_intersections), for closed manifold inputs."""
        self.self_intersections = self._core.self_intersections()
        if len(self.self_intersections):
            where = self.vertices[self.faces[self.self_intersections[:, 0]]].mean(axis=1)
            log.warning(
                "MeshSurface: the mesh intersects itself (%d pairs of faces cross, %s); "
                "its topology is not that of a surface: the remesh follows the union of "
                "what it encloses (winding number) and is marked incomplete",
                len(self.self_intersections),
                describe_regions(regions(where, REGION_LINK * float(np.ptp(self.vertices)))),
            )

    def input_report(
        self, unresolved: np.ndarray | None = None, mesh: tuple | None = None
    ) -> dict | None:
        """What in the input stands in the way of its topology, for the mesh's report.

        Parameters
        ----------
        unresolved : (k, 3) array, optional
            The run's refused refinement points: where two sheets of the
            input are closer than refinement can separate, the gap is
            measured there.
        mesh : (vertices, faces, euler or None), optional
            The output, checked against a known input topology
            (:func:`~._mesh_topology.topology_against_input`).

        Returns
        -------
        dict or None
            ``self_intersections`` (``pairs``, ``regions``) when the input
            intersects itself, ``close_sheets`` (``gap``, ``regions``) when
            refused points lie where two sheets of the input nearly touch,
            ``topology`` (given ``mesh`` and a known input topology),
            ``incomplete`` (the input rules out its topology, or the output
            does not have it) and a ``statement`` (empty when all is well);
            None when there is nothing to say.
        """
        out: dict = {"incomplete": False}
        said = []
        pairs = self.self_intersections
        if len(pairs):
            where = self.vertices[self.faces[pairs[:, 0]]].mean(axis=1)
            found = regions(where, REGION_LINK * self.radius)
            out["self_intersections"] = {"pairs": len(pairs), "regions": found}
            out["incomplete"] = True
            said.append(
                f"the input mesh intersects itself ({len(pairs)} pairs of faces cross, "
                f"{describe_regions(found)}): it bounds no solid with its topology, so the "
                "remesh (of the union it encloses, by the winding number) cannot keep it"
            )
        if unresolved is not None and len(unresolved):
            gap = self.sheet_gap(unresolved)
            close = gap < CLOSE_SHEETS * self.radius
            if close.any():
                found = regions(unresolved[close], REGION_LINK * self.radius)
                out["close_sheets"] = {
                    "points": int(close.sum()),
                    "gap": float(np.median(gap[close])),
                    "regions": found,
                }
                said.append(
                    f"two sheets of the input nearly touch where {int(close.sum())} refinement "
                    f"points were refused (median gap {np.median(gap[close]):.3g}, "
                    f"{describe_regions(found)}): closer than the spacing floor lets "
                    "refinement separate them"
                )
        kept = None if mesh is None else topology_against_input(self, *mesh)
        if kept is not None:
            out["topology"] = kept
            if not kept["kept"]:
                out["incomplete"] = True
                said.append(kept["statement"])
        if not said and kept is None:
            return None
        out["statement"] = "; ".join(said)
        return out

    @property
    def topology_known(self) -> bool:
        """The input is closed and does not intersect itself: each of its
        components bounds a solid, so the remesh's components are known."""
        return self.sign_method == "side" and not len(self.self_intersections)

    def input_components(self, points: np.ndarray) -> np.ndarray:
        """(N,) the input component (faces sharing vertices) of the face
        closest to each of ``points`` (that of an exact crossing: no query)."""
        face = self.crossing_faces(points)
        far = np.flatnonzero(face < 0)
        face[far] = self.closest_points(points[far])[1]
        return self._face_component[face]

    @cached_property
    def _face_component(self) -> np.ndarray:
        return components(self.faces, len(self.vertices))[1]

    @cached_property
    def input_euler(self) -> np.ndarray:
        """(k,) each input component's Euler characteristic, on its own faces."""
        m, label = self.input_face_count, self._face_component
        return component_euler(self.faces[:m], label[:m], int(label.max()) + 1, len(self.vertices))

    def unit_gradient_at(self, points: np.ndarray) -> np.ndarray:
        """(N,) bool: points where ``f``'s gradient, where it has one, is a unit
        vector, so that no singular point lies there: everywhere for a closed
        mesh, off the band about an open mesh's holes (``|4 (1 - 2w)| < 1``)."""
        pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        if self.sign_method == "side":
            return np.ones(len(pts), bool)
        return np.abs(self._winding_factor(pts)) >= 1.0

    def sheet_gap(self, points: np.ndarray) -> np.ndarray:
        """Distance across the thinnest part (inside or outside) of the input at
        points on it, ``(k,)``: twice the distance from the point to the
        medial axis along the closest face's normal, sampled up to
        ``CLOSE_SHEETS * R`` and bisected (``2 CLOSE_SHEETS R`` where it is
        farther)."""
        closest, face = self.closest_points(points)
        n = self._normals[face]
        cap = CLOSE_SHEETS * self.radius
        t = np.linspace(0.0, cap, GAP_SAMPLES + 1)[1:]
        gaps = []
        for sign in (1.0, -1.0):
            probe = closest[None] + sign * t[:, None, None] * n[None]
            d = self.distance(probe.reshape(-1, 3)).reshape(len(t), -1)
            behind = _behind(d, t[:, None])
            found = behind.any(axis=0)
            first = np.argmax(behind, axis=0)
            hi = np.where(found, t[first], cap)
            lo = np.where(found & (first > 0), t[np.maximum(first - 1, 0)], 0.0)
            # The samples only bracket the medial axis; bisect to its offset
            # (touching sheets would otherwise all read as one sample step).
            at = np.flatnonzero(found)
            for _ in range(GAP_BISECTIONS):
                mid = 0.5 * (lo[at] + hi[at])
                dm = self.distance(closest[at] + sign * mid[:, None] * n[at])
                past = _behind(dm, mid)
                hi[at] = np.where(past, mid, hi[at])
                lo[at] = np.where(past, lo[at], mid)
            gaps.append(2.0 * hi)
        return np.minimum(*gaps)


def _behind(d: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """Probes past the medial axis: there the distance to the mesh falls below
    the probe's offset from the surface."""
    return d < offset * (1 - 1e-6)
