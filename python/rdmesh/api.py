"""The public entry point: :func:`mesh_surface`."""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import replace

from ._tol import REGION_LINK
from ._validate import box_in_sphere, choice, integer, positive
from .features.given import ProtectingBalls
from .io.result import SurfaceMesh
from .refine.ball_spacing import with_ball_spacing
from .refine.criteria import FacetCriteria, Sizing
from .refine.feature_curves import has_given_curves, search_creases
from .refine.mesher import Budget, Mesher, forget_crossings, restart
from .refine.methods import METHODS, TOPOLOGIES
from .surfaces._mesh_thin import THIN_FLOOR, THIN_GROWTH, thin_parts
from .surfaces.expressions import Expression
from .surfaces.mesh import filled
from .surfaces.oracle import ImplicitSurface
from .surfaces.volume import VolumeSurface

log = logging.getLogger("rdmesh")


def mesh_surface(
    surface: ImplicitSurface,
    *,
    angle_bound: float = 30.0,
    radius_bound: float | Sizing | None = None,
    distance_bound: float | None = None,
    topology: str | None = None,
    method: str = "boissonnat-oudot",
    seed: int = 0,
    max_vertices: int | None = None,
    time_limit: float | None = None,
    seed_resolution: int = 64,
    progress: bool | Callable[[dict], None] = False,
    workers: int = 1,
    certify: bool | None = None,
    edge_size: float | Sizing | None = None,
) -> SurfaceMesh:
    """Mesh an implicit surface by restricted Delaunay refinement.

    Parameters
    ----------
    surface : ImplicitSurface
        The surface ``f = 0`` and a bounding sphere that strictly contains it.
    angle_bound : float, default 30
        Smallest triangle angle in degrees, at most 30 (where termination is
        proved); 0 disables it.
    radius_bound : float or callable, optional
        Largest radius of the surface Delaunay balls: a number, or a sizing
        field mapping ``(N, 3)`` points to ``N`` positive radii. Default
        (None): a twentieth of the bounding radius for Boissonnat-Oudot; no
        size bound at all for the topological-ball method, which then returns
        the coarsest mesh on which every test held. Below 0.1 times the local
        feature size the output is homeomorphic to the surface
        (Boissonnat-Oudot), provided the sampled crossing search found every
        crossing.
    distance_bound : float, optional
        Largest distance between a facet's circumcentre and its surface
        centre (an approximation bound); None disables it. A
        :class:`MeshSurface` is also measured against the output both ways
        at this bound, or without one at the radius bound, and where a run
        loses the topology of an input that does not intersect itself, the
        run is made once more with the radius bound lowered near the input's
        thin parts (``report["input"]["topology"]``,
        ``report["thin_parts"]``; incomplete if it is still lost).
    topology : {"manifold", "manifold-with-boundary", "non-manifold"}, optional
        As CGAL's Manifold_tag, Manifold_with_boundary_tag and
        Non_manifold_tag: what the final refinement stage repairs. Default
        (None): "manifold", or "manifold-with-boundary" for a surface clipped
        to a box (``ImplicitSurface(..., clip_box=...)``, or
        ``VolumeSurface(border="clipped")``), which accepts no other topology. With
        "manifold-with-boundary" (Boissonnat-Oudot only) the surface may also
        cross the bounding sphere: the mesh is the part inside. The curve
        where the surface meets the sphere is traced on a fine point set of
        the sphere and sampled at most the size bound apart (closer where it
        bends, for the distance bound); those samples are inserted first, and
        refinement points near the sphere are moved onto the curve, so the
        boundary vertices lie on the sphere and on the surface. The angle
        bound is applied to every triangle with at most one vertex on the
        sphere; those with two or three (an edge along the boundary curve)
        are exempt (their smallest angle is measured, not bounded: 19.6
        degrees on a gyroid, see the README).
        Sampled, not certified: ``certify`` is refused. On a surface with a
        clip box the same holds with the box faces in place of the sphere;
        the curve's corners, where it crosses a box edge, are samples.
    method : {"boissonnat-oudot", "topological-ball"}
        The refinement algorithm. "topological-ball" (Cheng-Dey-Ramos-Ray)
        first refines until the topological-ball tests hold (every Voronoi
        edge, facet and cell meets the surface in a ball; see
        :mod:`rdmesh.topology.tests`; some tests are sampled), then applies
        the criteria while keeping them. It seeds with the
        critical points of a random height function as well as the grid.
        Points driven by topology are refused below 0.01 x radius_bound, or
        without a size bound below 1e-4 x the bounding radius; refused points
        go to ``SurfaceMesh.unresolved`` and the report then does not claim
        the property. Every method fills ``SurfaceMesh.report``.
    seed : int
        Seed of every random choice; the same seed gives the same mesh.
    max_vertices : int, optional
        Stop when the mesh would exceed this many samples.
    time_limit : float, optional
        Stop after about this many seconds: a round predicted to end past the
        limit is not started (the prediction: the run's time per point
        inserted or present, times the round's points, and at least the last
        round's time); the exception's message says when it stopped and why.
    seed_resolution : int, default 64
        Cells across the bounding ball of the grid scan that finds the
        components; components narrower than about 1.7 cells may be missed.
        Expression surfaces (an interval subdivision) and closed volumes (a
        search on the interpolant) also get a proven search that seeds every
        component, with either method and with or without ``certify``; the
        report's ``seeding`` then says ``proven``.
    progress : bool or callable, default False
        True shows a progress bar on stderr; a callable receives a dict
        (``round``, ``stage``, ``inserted``, ``vertices``, ``seconds``) after
        every round.
    workers : int, default 1
        Threads that evaluate facets at once. numpy releases the GIL, so 2
        uses both cores of a 2-core machine; ``f`` must then be thread-safe
        (pure numpy functions are).
    certify : bool, optional
        Prove what interval arithmetic can prove (expression surfaces only:
        :meth:`ImplicitSurface.from_expression`). It seeds every component
        with proof (an interval subdivision, Plantinga-Vegter/Snyder), and
        it proves the crossings of every Voronoi edge, refining until each
        restricted facet's dual edge crosses once, transversally, and every
        other edge not at all; and it proves the loop and silhouette tests
        on every Voronoi facet and cell, refining where a proof fails. When
        every step is proven, ``topology_certified`` is True. Default (None):
        on for expression surfaces with the topological-ball method, off
        otherwise (with Boissonnat-Oudot the proofs cost several times the
        run); True for a surface that is not an expression raises
        ValueError. The report gives each test's level (``proven`` or
        ``sampled``).
    edge_size : float or callable, optional
        Largest length of the mesh edges along feature curves (CGAL's
        ``edge_size``): the spacing of the protecting balls' centres, whose
        radii are 0.9 times their smaller spacing. A number or a sizing
        field. Default (None): the radius bound, or 0.3 times it on a
        :class:`MeshSurface` whose sharp-edge curves are short against its
        area (at most 2 % more vertices: :mod:`rdmesh.refine.ball_spacing`).
        Feature curves (creases,
        sharp edges, clip boundaries: ``ImplicitSurface(features=...)``)
        are protected by balls centred on them (:mod:`rdmesh.features`),
        each consecutive pair of centres kept a mesh edge, every corner a
        vertex; next to the balls the angle, size and distance criteria are
        relaxed as in CGAL's Mesh_3 (``SurfaceMesh.features`` says what
        held). With ``edge_size`` at most 0.3 times a numeric
        ``radius_bound``, the angle bound is held next to the balls too,
        wherever the refinement point lands at least 0.7 ball radii out,
        and seeds are kept 2 ball radii off: on the benchmarks'
        thin-handled genus-2 solid that gave 30 degrees everywhere, and on
        crease-dominated shapes far fewer triangles below the bound (a
        measurement, not a guarantee), for more vertices along the curves.
        Boissonnat-Oudot only: "topological-ball" and ``certify`` refuse
        given feature curves. Balls placed beforehand
        (``features=ProtectingBalls(...)``) are inserted as they are and
        not repaired: a failed feature check makes the mesh incomplete.
        The creases of an expression's ``min``, ``max`` and ``abs`` and of
        a :mod:`rdmesh.csg` tree are
        found first (``features="auto"``, the default;
        :func:`rdmesh.creases.find_creases`, ``report["creases"]``) and
        protected the same way; a surface with creases found is meshed by
        "boissonnat-oudot" without ``certify`` whatever ``method`` says
        (with a warning, and the report's note).

    Returns
    -------
    SurfaceMesh

    Raises
    ------
    rdmesh.FeatureError
        (a ValueError) A given feature curve is not on the surface, or the
        curves cannot be protected (curves or corners closer than 1e-6 R),
        or an expression with features on uses ``sign``, ``floor`` or
        ``ceil`` (its surface jumps).
    ValueError
        Invalid criteria, method or topology; given feature curves with the
        topological-ball method or ``certify``; a surface clipped to a box
        with a topology other than "manifold-with-boundary", the
        topological-ball method or ``certify=True``, or whose ``clip_box``
        (reassigned since the surface was made) is no longer a valid box
        inside the bounding sphere.
    rdmesh.OracleError
        ``f`` raised, returned the wrong shape or a non-finite value.
    rdmesh.EmptySurfaceError
        No surface inside the bounding sphere.
    rdmesh.BoundingSphereError
        The surface reaches the bounding sphere (topology "manifold" or
        "non-manifold"; "manifold-with-boundary" meshes the part inside).
    rdmesh.BudgetExceeded
        ``max_vertices`` or ``time_limit`` stopped the run, or the memory
        available (Linux: ``MemAvailable``, or a cgroup's limit) would not
        hold the next round and the run's end (estimated at 4 KB per point
        inserted and 1 KB per sample; :mod:`rdmesh.refine.memory`); the
        partial mesh is attached as ``.mesh`` and flagged ``complete=False``
        (its report names the regions where tests still fail).
    rdmesh.Interrupted
        Ctrl-C (KeyboardInterrupt) stopped the run; a StoppedEarly (not a
        BudgetExceeded) with the partial mesh attached.
    rdmesh.RefinementStalled
        A refinement batch added no new sample; a BudgetExceeded with the
        partial mesh attached.

    Notes
    -----
    Points left unresolved (below the spacing floor, or failing tests without
    a refinement point) do not raise: the mesh comes back with
    ``complete=False`` and lists them in ``SurfaceMesh.unresolved``.
    """
    if not isinstance(surface, ImplicitSurface):
        raise ValueError(
            f"surface must be an rdmesh.ImplicitSurface, got {type(surface).__name__}"
        )
    choice("method", method, METHODS)
    topology = _topology(surface, topology, method)
    if method == "topological-ball" and topology != "manifold":
        raise ValueError(
            f"method 'topological-ball' always produces a closed manifold; topology "
            f"{topology!r} is only for 'boissonnat-oudot' (surfaces that leave the "
            "bounding sphere are not supported by 'topological-ball')"
        )
    criteria = FacetCriteria(angle_bound, radius_bound, distance_bound)  # checked first
    if max_vertices is not None:
        max_vertices = integer("max_vertices", max_vertices, lo=1)
    if time_limit is not None:
        positive("time_limit", time_limit, " of seconds")
    seed_resolution = integer("seed_resolution", seed_resolution, 8, 256)
    try:
        seed = int(seed)
    except (TypeError, ValueError):
        raise ValueError(f"seed must be an integer, got {seed!r}") from None
    if isinstance(workers, float):
        raise ValueError(f"workers must be an integer from 1 to 64, got {workers!r}")
    workers = integer("workers", workers, 1, 64)
    expression = isinstance(surface.f, Expression)
    if certify is None:
        certify = expression and method == "topological-ball"
    elif certify not in (True, False):
        raise ValueError(f"certify must be True, False or None, got {certify!r}")
    elif certify and not expression:
        raise ValueError(
            "certify=True needs an expression surface (ImplicitSurface.from_expression): "
            "nothing can be proven about a plain function between its samples"
        )
    if certify and topology == "manifold-with-boundary":
        raise ValueError(
            "certify=True is not available with topology='manifold-with-boundary': the "
            "proofs assume a closed surface strictly inside the bounding sphere"
        )
    given = has_given_curves(surface)
    given |= isinstance(surface.features, ProtectingBalls)
    holes = getattr(surface, "holes", None)
    if holes is not None and holes.curves and (method != "boissonnat-oudot" or certify):
        raise ValueError(
            f"{surface.name!r} is an open mesh whose holes are kept: their rims are protected "
            "curves, which need method='boissonnat-oudot' without certify; or remesh it "
            "closed with MeshSurface(..., holes='fill')"
        )
    if given and (method != "boissonnat-oudot" or certify):
        raise ValueError(
            "feature curves (features=) need method='boissonnat-oudot' without certify: the "
            "topological-ball tests and the proofs assume a smooth surface"
        )
    if edge_size is not None and not callable(edge_size):
        edge_size = positive("edge_size", edge_size)
    if progress is not True and progress is not False and not callable(progress):
        raise ValueError(f"progress must be True, False or a callable, got {progress!r}")
    creases = search_creases(surface, topology, seed, seed_resolution)
    if creases is not None and creases.curves and (method != "boissonnat-oudot" or certify):
        creases.note = (
            f"{len(creases.curves)} creases found: meshed by 'boissonnat-oudot' with the creases "
            f"protected instead of {method!r}{' with certify' if certify else ''} (the "
            "topological-ball tests and the proofs assume a smooth surface); not certified"
        )
        log.warning("%s", creases.note)
        method, certify = "boissonnat-oudot", False
    if radius_bound is None and method == "boissonnat-oudot":
        criteria = FacetCriteria(angle_bound, surface.radius / 20.0, distance_bound)
    criteria, edge_size = with_ball_spacing(surface, criteria, edge_size)
    budget = Budget(max_vertices=max_vertices, time_limit=time_limit)
    mesher = Mesher(
        surface,
        criteria,
        method=method,
        topology=topology,
        seed=seed,
        budget=budget,
        seed_resolution=seed_resolution,
        progress=progress if callable(progress) else None,
        workers=workers,
        certify=bool(certify),
        edge_size=edge_size,
        creases=creases,
    )
    try:
        if progress is True:
            from .progress import ProgressBar

            with ProgressBar() as bar:
                mesher.progress = bar.update
                return _thin_parts_kept(mesher, _kept_or_filled(mesher))
        return _thin_parts_kept(mesher, _kept_or_filled(mesher))
    finally:
        forget_crossings(surface)  # their memory goes with the run


def _kept_or_filled(mesher: Mesher):
    """The mesher's run; for an open mesh whose rims could not be protected (the
    holes could not be kept), the run again with them filled (``holes="fill"``)
    in the time left, if any (else the first run's mesh, closed by its caps)."""
    mesh = mesher.run()
    holes = (mesh.report or {}).get("holes")
    if holes is None or holes["cut"] or _out_of_time(mesher, mesh):
        return mesh
    log.warning(
        "%s: the rims of its %d holes could not be protected (%s); meshing it again with "
        "the holes filled (holes='fill')", mesher.surface.name, holes["rims"],
        mesh.stats.get("stop_reason", ""),
    )  # fmt: skip
    again = _run_again(mesher, mesh, filled(mesher.surface))
    again.report["holes"] = {**holes, "closed_by": "winding number", "filled_again": True,
                             "first_run_seconds": mesh.stats["seconds"]}  # fmt: skip
    again.report["statement"] += (
        f" The input's {holes['rims']} holes could not be kept (their rims could not be "
        "protected): they are filled by the winding number's patches (holes='fill')."
    )
    return again


def _out_of_time(mesher: Mesher, first: SurfaceMesh) -> bool:
    """Whether the first run used up the time limit (no time for another)."""
    limit = mesher.budget.time_limit
    return limit is not None and first.stats["seconds"] >= limit


def _run_again(mesher: Mesher, first: SurfaceMesh, surface: ImplicitSurface) -> SurfaceMesh:
    """The mesher's run from scratch on ``surface`` in the time the ``first``
    run left; its ``seconds`` are both runs'."""
    limit = mesher.budget.time_limit
    if limit is not None:  # the two runs share the time limit
        mesher.budget = Budget(mesher.budget.max_vertices, limit - first.stats["seconds"])
    restart(mesher, surface)
    again = mesher.run()
    again.stats["seconds"] += first.stats["seconds"]
    return again


def _thin_parts_kept(mesher: Mesher, mesh: SurfaceMesh) -> SurfaceMesh:
    """``mesh``; or, where it lost the topology of a closed input mesh and the
    input has parts thinner than the radius bound, the run again with the bound
    lowered near them (:mod:`rdmesh.surfaces._mesh_thin`) in the time left."""
    topo = ((mesh.report or {}).get("input") or {}).get("topology")
    r = mesher.criteria.radius_bound
    if topo is None or topo["kept"] or not isinstance(r, float) or mesher.criteria.local_bound:
        return mesh
    if _out_of_time(mesher, mesh):
        return mesh
    thin = thin_parts(mesher.surface, r, THIN_FLOOR * r)
    if thin is None or thin.vertices_asked() > THIN_GROWTH * len(mesh.vertices):
        return mesh
    said = thin.report(REGION_LINK * mesher.surface.radius)
    log.warning("%s: %s; meshing it again", mesher.surface.name, said["statement"])
    mesher.criteria = replace(mesher.criteria, local_bound=thin.sizing)
    again = _run_again(mesher, mesh, mesher.surface)
    again.report["thin_parts"] = {**said, "first_run_seconds": mesh.stats["seconds"]}
    again.report["statement"] += f" The input: {said['statement']}."
    return again


def _topology(surface: ImplicitSurface, topology: str | None, method: str) -> str:
    """The topology to use: the default per surface, checked against its clip box."""
    boxed = getattr(surface, "clip_box", None) is not None
    if topology is None:
        topology = "manifold-with-boundary" if boxed else "manifold"
    choice("topology", topology, TOPOLOGIES)
    if not boxed:
        return topology
    # For a volume, the closed border; for any other surface, no box.
    closed = (
        "border='closed' for a closed surface"
        if isinstance(surface, VolumeSurface)
        else "clip_box=None to mesh it inside the bounding sphere"
    )
    if method != "boissonnat-oudot":
        raise ValueError(
            f"method {method!r} cannot mesh {surface.name!r}, which is clipped to a box "
            "(a surface with a boundary): use method='boissonnat-oudot' (with "
            f"topology='manifold-with-boundary', the default for it), or {closed}"
        )
    if topology != "manifold-with-boundary":
        raise ValueError(
            f"topology {topology!r} cannot mesh {surface.name!r}, which is clipped to a box: "
            "its mesh has a boundary on the box faces; use topology='manifold-with-boundary' "
            f"(the default for it), or {closed}"
        )
    # Checked when the surface was made; again here, as the attribute may
    # have been reassigned since.
    box_in_sphere(surface.clip_box, surface.centre, surface.radius, surface.name)
    return topology
