"""SurfaceMesh: the output triangle mesh, its statistics and exports."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._geometry import ball_radii, min_angles
from ..features.check import MeshFeatures
from ..topology.complex import (
    component_topology,
    is_closed_manifold,
    is_manifold_with_boundary,
)

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
        ``evaluations`` (points at which ``f`` was evaluated), ``segment_queries``
        (exact crossings of a closed mesh), ``slope_bound``, ``facets_cleared``, ``fine_clearing``
        (:mod:`rdmesh.sampling`), ``distance_check`` (:mod:`rdmesh.refine.deviation`),
        ``inserted`` per stage, ``unresolved``, ``phase_seconds`` and more. ``phase_seconds`` adds
        up the wall time of each phase of the main thread; its
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
        ``tbp_holds``, ``certified``, ``tests`` (per test: ``held``,
        ``level``, ``violations``, ``repaired``, ``basis``), ``seeding``,
        ``components``, ``euler``, ``boundary_loops``, ``closed_manifold``,
        ``boundary``, ``unresolved_regions``, ``violation_regions``,
        ``critical_points``, ``relabelled``, ``pockets``, ``statement`` and ``features``
        (the feature check, None without protected curves);
        :mod:`rdmesh.topology.report` says what each holds.
    features : MeshFeatures or None
        The protected feature curves as mesh vertex indices, the corners and
        the feature check (:class:`rdmesh.MeshFeatures`); None without.
    weights : (N,) float64 or None
        A protecting ball's radius squared at its centre, 0 elsewhere; None
        when nothing was protected.
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
        return _from_facets(cls, samples, tri, centres, unresolved)

    @property
    def topology_certified(self) -> bool:
        """True only when every topological-ball test and the seeding are proven
        (report ``certified``).

        Tests that held only on samples (see each test's ``level`` in
        :attr:`report`) do not certify. Only expression surfaces in certify
        mode (the topological-ball method's default) can have every test
        proven, by interval arithmetic; a plain numpy function, a mesh or a
        volume never does. ``report["tbp_holds"]`` says whether all tests
        held, and ``report["statement"]`` which were proven.
        """
        return bool(self.report.get("certified", False))

    @property
    def ball_radii(self) -> np.ndarray:
        """Radius of each face's surface Delaunay ball (power radius), ``(M,)``."""
        return _ball_radii(self)

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
        return is_closed_manifold(self.faces, len(self.vertices))

    def is_manifold_with_boundary(self) -> bool:
        """True when every edge has one or two faces, every vertex one fan of
        faces, and some edge only one (a boundary): a surface meshed with
        ``topology="manifold-with-boundary"`` that leaves the bounding sphere."""
        return is_manifold_with_boundary(self.faces, len(self.vertices))

    def topology(self) -> dict[str, Any]:
        """Components, and Euler characteristic, boundary loops and genus of each.

        Genus ``(2 - chi - b) / 2`` for a component with ``b`` boundary
        loops assumes orientable components, which every surface embedded in
        space without self-intersection and cut by a sphere is.
        """
        return _topology(self)

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
        _check_format(path)
        self.to_trimesh().export(os.fspath(path))

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
        return _summary(self)


def _from_facets(cls, samples, tri, centres, unresolved) -> SurfaceMesh:
    """:meth:`SurfaceMesh.from_facets`."""
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


def _ball_radii(mesh: SurfaceMesh) -> np.ndarray:
    """:attr:`SurfaceMesh.ball_radii`."""
    return ball_radii(mesh.vertices, mesh.weights, mesh.faces, mesh.facet_centres)


def _topology(mesh: SurfaceMesh) -> dict[str, Any]:
    """:meth:`SurfaceMesh.topology`."""
    chi, loops = component_topology(mesh.faces, len(mesh.vertices))
    return {
        "components": len(chi),
        "euler": chi,
        "boundary_loops": loops,
        "genus": [(2 - c - b) / 2 for c, b in zip(chi, loops, strict=True)],
        "closed_manifold": mesh.is_closed_manifold(),
        "manifold_with_boundary": mesh.is_manifold_with_boundary(),
    }


def _check_format(path: str | os.PathLike) -> None:
    """ValueError unless :meth:`SurfaceMesh.save` writes the path's format."""
    path = os.fspath(path)
    ext = os.path.splitext(path)[1].lower().lstrip(".")
    if ext not in MESH_FORMATS:
        raise ValueError(
            f"cannot write {path!r}: unknown mesh format {ext!r}; use one of "
            f"{', '.join(MESH_FORMATS)}"
        )


def _creases_line(c: dict) -> str:
    """The summary's line on the creases found in an expression or CSG tree."""
    if c.get("note", "").startswith("not searched"):
        return f"creases: {c['note']}"
    how = (
        "the interval search settled every box no traced crease crosses"
        if c["level"] == "intervals"
        else "seeded from the grid only, no interval search"
    )
    line = f"creases found: {c['curves']} curves, {c['corners']} corners ({how})"
    if c["unresolved"]:
        line += f"; {len(c['unresolved'])} places UNRESOLVED (report['creases'])"
    return line


def _summary(mesh: SurfaceMesh) -> str:
    """:meth:`SurfaceMesh.summary`."""
    topo = mesh.topology()
    genus = ", ".join(f"{g:g}" for g in topo["genus"])
    lines = [
        f"vertices {len(mesh.vertices)}, faces {len(mesh.faces)}",
        f"min angle {mesh.min_angle:.2f} deg",
        f"components {topo['components']} (genus {genus}), "
        f"closed manifold: {'yes' if topo['closed_manifold'] else 'no'}"
        + (
            f", boundary loops {sum(topo['boundary_loops'])}"
            if topo["manifold_with_boundary"]
            else ""
        ),
        f"time {mesh.stats.get('seconds', float('nan')):.2f} s, "
        f"{mesh.stats.get('rounds', 0)} rounds, "
        f"{mesh.stats.get('evaluations', 0)} evaluations of f"
        + (
            f", {mesh.stats['segment_queries']} exact segment queries"
            if mesh.stats.get("segment_queries")
            else ""
        ),
    ]
    if mesh.features is not None:
        f = mesh.features
        lines.append(
            (
                f"features: {len(f.curves)} curves, {len(f.corners)} corners kept"
                if f.held
                else f"features: {len(f.curves)} curves, {len(f.corners)} corners; NOT all kept "
                f"({f.edges_kept} of {f.edges} curve edges, {f.corners_kept} corners)"
            )
            + ("; small balls, angle bound held next to them" if f.angle_held else "")
        )
    creases = mesh.report.get("creases") if mesh.report else None
    if creases is not None:
        lines.append(_creases_line(creases))
    holes = mesh.report.get("holes") if mesh.report else None
    if holes is not None:
        lines.append(
            f"holes: {holes['rims']} kept, their rims the boundary (closed while meshing by "
            f"the {holes['closed_by']}, cut off)"
            if holes["cut"]
            else f"holes: {holes['rims']} NOT kept (rims not protected): closed by the "
            f"{holes['closed_by']}"
        )
    line = _input_topology_line(mesh.report)
    if line:
        lines.append(line)
    if not mesh.complete:
        lines.append("INCOMPLETE: " + str(mesh.stats.get("stop_reason", "budget")))
    if len(mesh.unresolved):
        lines.append(f"unresolved refinement points: {len(mesh.unresolved)}")
    if mesh.report:
        failed = [k for k, t in mesh.report["tests"].items() if t["held"] is False]
        if mesh.report.get("boundary") is not None:
            box = mesh.report["boundary"].get("domain") == "box"
            where = "its clip box" if box else "the bounding sphere"
            held = f"not applicable (the surface leaves {where}), NOT certified"
            failed = []
        elif mesh.report.get("certified"):
            held = "certified"
        elif mesh.report["tbp_holds"]:
            held = "held on samples, NOT certified"
        else:
            held = "NOT certified"
        lines.append(
            "topological ball property: "
            + held
            + (f" (failed: {', '.join(failed)})" if failed else "")
        )
    return "\n".join(lines)


def _input_topology_line(report: dict | None) -> str:
    """The summary's line on a closed input's topology, if it is known."""
    topo = ((report or {}).get("input") or {}).get("topology")
    if topo is None:
        return ""
    inp = topo["input"]
    n = inp["components"]
    line = f"input's topology ({n} component{'s' * (n != 1)}, Euler {_short(inp['euler'])}): "
    line += "kept" if topo["kept"] else "NOT kept"
    if (report or {}).get("thin_parts") is not None:
        thin = report["thin_parts"]
        line += f"; radius bound lowered to {thin['least_bound']:.3g} near its thin parts"
    return line


def _short(values: list) -> str:
    return ", ".join(str(v) for v in values[:6]) + (", ..." if len(values) > 6 else "")
