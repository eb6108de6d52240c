"""SurfaceMesh: the output triangle mesh, its statistics and exports."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..features.check import MeshFeatures
from ..refine.criteria import min_angles
from ..topology.complex import complex_status, component_topology

#: File formats :meth:`SurfaceMesh.save` writes (through trimesh).
MESH_FORMATS = ("ply", "obj", "stl", "off", "glb", "gltf", "3mf", "dae")


@dataclass
class SurfaceMesh:
    """A triangle mesh of a surface.

    Attributes
    ----------
    vertices : (N, 3) float64
        Vertex positions; every vertex is a sample on the surface.
    faces : (M, 3) int64
        Triangles, oriented outward (normals point towards ``f > 0``).
    facet_centres : (M, 3) float64
        Centre of each face's surface Delaunay ball: where its dual Voronoi
        edge meets the surface. The ball radius is the distance to any vertex
        (the power distance ``sqrt(d^2 - w)`` to a protecting ball's centre).
    stats : dict
        Run statistics: ``seconds``, ``rounds``, ``vertices``, ``faces``,
        ``evaluations`` (points at which ``f`` was evaluated), ``inserted`` per
        stage, ``unresolved``, ``phase_seconds`` and more. ``phase_seconds``
        adds up the wall time of each phase of the main thread; its
        ``core_changed_facets`` and ``core_update_facets`` are the core
        thread's busy time, which overlaps them.
    complete : bool
        False when a budget stopped refinement early (see :class:`BudgetExceeded`),
        or when points were left unresolved. A complete mesh meshed with
        ``topology="manifold"`` is a closed 2-manifold.
    unresolved : (k, 3) float64
        Where refinement stopped short: refinement points refused by the
        spacing floor (closer than it to the samples), and the places of
        failing tests that found no refinement point (an isolated sample, a
        silhouette cell); empty for a fully refined mesh.
    report : dict
        The topology report (:func:`rdmesh.topology.topology_report`), the
        same fields for every method, computed on the final samples:

        ``tbp_holds``
            True when every topological-ball test held (some only on samples),
            nothing was left unresolved and the run completed.
        ``certified``
            True only when, besides, every test is proven
            (:attr:`topology_certified`).
        ``tests``
            Per test (``voronoi_edge``, ``voronoi_facet``, ``voronoi_loop``,
            ``disk``, ``isolated``, ``silhouette``): ``held``, ``level``
            (``proven``, ``sampled``, ``failed`` or ``not tested``), ``violations`` at the end,
            ``repaired`` (points inserted to repair it), ``basis`` ("exact",
            "sampled", ...) and what it checks. With ``certify``,
            ``voronoi_edge`` also has ``proof``: the interval check of every
            Voronoi edge's crossings.
        ``seeding``
            How the components were found: ``level`` ``proven`` (interval
            subdivision, certify mode: a seed on every component) or
            ``sampled`` (grid scan), with the boxes' figures.
        ``components``, ``euler``, ``boundary_loops``, ``closed_manifold``
            Of the output mesh.
        ``boundary``
            A surface that leaves the bounding sphere or its clip box
            (``topology="manifold-with-boundary"``): ``domain`` ("sphere" or
            "box"), ``curve_loops`` traced on it, ``edge_crossings`` (box:
            where the curve crosses a box edge, each a sample),
            ``mesh_loops``, ``loops_match``, ``genus`` per component from
            chi = 2 - 2g - b and ``euler_consistent`` (a whole genus, at
            least 0); None otherwise.
        ``unresolved_regions``, ``violation_regions``
            Where points were refused by the spacing floor, or tests still fail:
            ``centre``, ``radius`` and ``points`` of each cluster.
        ``critical_points``
            Topological-ball method: the height-function critical points used
            as seeds and whether their Morse count matches the mesh.
        ``statement``
            What is certified and what rests on sampling, in words.
        ``features``
            With protected feature curves: how many curves, corners and
            balls, and the feature check (``held``, ``edges_kept`` of
            ``edges``, ``corners_kept``, where it ``failed``); None without.
    features : MeshFeatures or None
        The protected feature curves (creases, sharp edges, clip boundaries)
        as mesh vertex indices in order, the corners, and the outcome of the
        feature check (:class:`rdmesh.features.MeshFeatures`); None when
        nothing was protected.
    weights : (N,) float64 or None
        Each vertex's weight: a protecting ball's radius squared (ball
        centres are vertices on the feature curves), 0 for the other
        vertices; None when nothing was protected.
    """

    vertices: np.ndarray
    faces: np.ndarray
    facet_centres: np.ndarray
    stats: dict[str, Any] = field(default_factory=dict)
    complete: bool = True
    unresolved: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    report: dict[str, Any] = field(default_factory=dict)
    features: MeshFeatures | None = None
    weights: np.ndarray | None = None

    @classmethod
    def from_facets(
        cls, samples: np.ndarray, tri: np.ndarray, centres: np.ndarray, unresolved: np.ndarray
    ) -> SurfaceMesh:
        """The mesh of restricted facets ``tri`` (sample ids, oriented) with their
        surface centres: only the samples they use, renumbered; deterministic
        order (each face starts at its smallest index, faces sorted)."""
        used, faces = np.unique(tri, return_inverse=True)
        faces = faces.reshape(-1, 3).astype(np.int64)
        shift = np.argmin(faces, axis=1)
        faces = faces[np.arange(len(faces))[:, None], (shift[:, None] + np.arange(3)) % 3]
        order = np.lexsort(faces.T[::-1])
        mesh = cls(
            vertices=samples[used],
            faces=faces[order],
            facet_centres=centres[order],
            unresolved=unresolved,
        )
        mesh.stats.update(vertices=len(used), faces=len(faces))
        return mesh

    @property
    def topology_certified(self) -> bool:
        """True only when every topological-ball test and the seeding are proven
        (report ``certified``).

        Tests that held only on samples (see each test's ``level`` in
        :attr:`report`) do not certify. In certify mode (expression surfaces)
        the seeding, the Voronoi-edge crossings and the Voronoi-facet crossing
        count are proven; the loop and silhouette tests are still sampled, so
        this is False for every surface today; ``report["tbp_holds"]`` says
        whether all tests held.
        """
        return bool(self.report.get("certified", False))

    @property
    def ball_radii(self) -> np.ndarray:
        """Radius of each face's surface Delaunay ball, ``(M,)``."""
        d = self.facet_centres - self.vertices[self.faces[:, 0]]
        r2 = np.einsum("ij,ij->i", d, d)
        if self.weights is not None:
            r2 = np.maximum(r2 - self.weights[self.faces[:, 0]], 0.0)
        return np.sqrt(r2)

    @property
    def angles(self) -> np.ndarray:
        """The smallest angle of each face in degrees, ``(M,)``."""
        return min_angles(self.vertices[self.faces])

    @property
    def min_angle(self) -> float:
        """The smallest angle of the mesh in degrees (nan without faces)."""
        return float(self.angles.min()) if len(self.faces) else float("nan")

    def is_closed_manifold(self) -> bool:
        """True when every edge has two faces and every vertex one fan of faces."""
        if len(self.faces) == 0:
            return False
        st = complex_status(self.faces, len(self.vertices))
        used = np.unique(self.faces)
        return bool(np.all(st.edge_count == 2) and np.all(st.vertex_fans[used] == 1))

    def is_manifold_with_boundary(self) -> bool:
        """True when every edge has one or two faces, every vertex one fan of
        faces, and some edge only one (a boundary): a surface meshed with
        ``topology="manifold-with-boundary"`` that leaves the bounding sphere."""
        if len(self.faces) == 0:
            return False
        st = complex_status(self.faces, len(self.vertices))
        used = np.unique(self.faces)
        return bool(
            np.all(st.edge_count <= 2)
            and np.any(st.edge_count == 1)
            and np.all(st.vertex_fans[used] == 1)
        )

    def topology(self) -> dict[str, Any]:
        """Components, and Euler characteristic, boundary loops and genus of each.

        Genus ``(2 - chi - b) / 2`` for a component with ``b`` boundary
        loops assumes orientable components, which every surface embedded in
        space without self-intersection and cut by a sphere is.
        """
        chi, loops = component_topology(self.faces, len(self.vertices))
        return {
            "components": len(chi),
            "euler": chi,
            "boundary_loops": loops,
            "genus": [(2 - c - b) / 2 for c, b in zip(chi, loops, strict=True)],
            "closed_manifold": self.is_closed_manifold(),
            "manifold_with_boundary": self.is_manifold_with_boundary(),
        }

    def to_trimesh(self):
        """The mesh as a :class:`trimesh.Trimesh` (indices kept, no merging)."""
        import trimesh

        return trimesh.Trimesh(vertices=self.vertices, faces=self.faces, process=False)

    def save(self, path: str | os.PathLike) -> None:
        """Write the mesh in any format trimesh writes, chosen by the extension.

        Raises
        ------
        ValueError
            If trimesh cannot write that extension.
        OSError
            If the file cannot be written.
        """
        path = os.fspath(path)
        ext = os.path.splitext(path)[1].lower().lstrip(".")
        if ext not in MESH_FORMATS:
            raise ValueError(
                f"cannot write {path!r}: unknown mesh format {ext!r}; use one of "
                f"{', '.join(MESH_FORMATS)}"
            )
        self.to_trimesh().export(path)

    def render(
        self, path: str | os.PathLike, *, title: str | None = None, size: int = 800
    ) -> None:
        """Write a shaded picture of the mesh (PNG by extension) with headless matplotlib.

        ``size`` is the width and height in pixels. Needs matplotlib
        (``pip install 'rdmesh[render]'``); see :func:`rdmesh.io.render.render`.
        """
        from .render import render

        render(self.vertices, self.faces, path, title=title, size=size)

    def summary(self) -> str:
        """A few lines: size, angles, topology, time."""
        topo = self.topology()
        genus = ", ".join(f"{g:g}" for g in topo["genus"])
        lines = [
            f"vertices {len(self.vertices)}, faces {len(self.faces)}",
            f"min angle {self.min_angle:.2f} deg",
            f"components {topo['components']} (genus {genus}), "
            f"closed manifold: {'yes' if topo['closed_manifold'] else 'no'}"
            + (
                f", boundary loops {sum(topo['boundary_loops'])}"
                if topo["manifold_with_boundary"]
                else ""
            ),
            f"time {self.stats.get('seconds', float('nan')):.2f} s, "
            f"{self.stats.get('rounds', 0)} rounds, "
            f"{self.stats.get('evaluations', 0)} evaluations of f",
        ]
        if self.features is not None:
            f = self.features
            lines.append(
                f"features: {len(f.curves)} curves, {len(f.corners)} corners kept"
                if f.held
                else f"features: {len(f.curves)} curves, {len(f.corners)} corners; NOT all kept "
                f"({f.edges_kept} of {f.edges} curve edges, {f.corners_kept} corners)"
            )
        if not self.complete:
            lines.append("INCOMPLETE: " + str(self.stats.get("stop_reason", "budget")))
        if len(self.unresolved):
            lines.append(f"unresolved refinement points: {len(self.unresolved)}")
        if self.report:
            failed = [k for k, t in self.report["tests"].items() if t["held"] is False]
            if self.report.get("boundary") is not None:
                box = self.report["boundary"].get("domain") == "box"
                where = "its clip box" if box else "the bounding sphere"
                held = f"not applicable (the surface leaves {where}), NOT certified"
                failed = []
            elif self.report.get("certified"):
                held = "certified"
            elif self.report["tbp_holds"]:
                held = "held on samples, NOT certified"
            else:
                held = "NOT certified"
            lines.append(
                "topological ball property: "
                + held
                + (f" (failed: {', '.join(failed)})" if failed else "")
            )
        return "\n".join(lines)
