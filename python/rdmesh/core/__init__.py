"""The restricted Delaunay core: CGAL's 3D Delaunay triangulation in C++.

A thin wrapper over the extension ``_rdt`` (see ``_rdt.pyi`` for its
signatures): the triangulation with per-facet restricted flags and surface
centres, batch insertion, the facets whose dual changed in each round with
their dual segments sampled, Voronoi facets, and the greedy independent set
of balls that makes a batch a valid sequential run; ``VolumeSampler``, the
B-spline sampler of :class:`rdmesh.VolumeSurface`; and ``MeshDistance``, the
distance, side and winding-number queries behind ``MeshSurface``;
``evaluate_intervals``, interval bounds of a compiled expression over boxes
(:mod:`rdmesh.surfaces.interval_program`, with the opcodes ``INTERVAL_OPS``);
``boxes_outside_cells``, the Voronoi-cell pruning of the proven
topological-ball tests; and ``prove_boxes``, their whole subdivision, owner by
owner, over the cores; and ``isolate_segment_roots``, proven root isolation on
segments. Work that the core spreads over threads uses ``usable_cores()`` of
them, the CPUs this process may run on.

Facet flag bits (set by Python, kept by the core per facet):
``RESTRICTED`` (the dual meets the surface), ``BAD`` (fails a criterion),
``OUTWARD`` (outside lies along the dual segment's direction), ``TOPO`` (the
dual crosses several times or tangentially), ``KNOWN`` (the crossing search
was clean: no crossing, or one transversal crossing, with no failed root
search; the core then derives the facet's next status itself when an
insertion only shortens its dual, and does not hand it out again).
"""

from ._rdt import (
    BAD,
    CGAL_VERSION,
    INTERVAL_OPS,
    INTERVAL_REL_WIDENING,
    KNOWN,
    OUTWARD,
    RESTRICTED,
    TOPO,
    GridField,
    MeshDistance,
    PointMap,
    RestrictedDelaunay,
    VolumeSampler,
    boxes_outside_cells,
    complex_status,
    evaluate_intervals,
    isolate_segment_roots,
    prove_boxes,
    sample_segments,
    scan_samples,
    segment_pieces,
    select_independent,
    trim_heap,
    usable_cores,
)

__all__ = [
    "BAD",
    "CGAL_VERSION",
    "INTERVAL_OPS",
    "INTERVAL_REL_WIDENING",
    "KNOWN",
    "GridField",
    "MeshDistance",
    "PointMap",
    "OUTWARD",
    "RESTRICTED",
    "TOPO",
    "RestrictedDelaunay",
    "VolumeSampler",
    "boxes_outside_cells",
    "complex_status",
    "evaluate_intervals",
    "isolate_segment_roots",
    "prove_boxes",
    "sample_segments",
    "scan_samples",
    "segment_pieces",
    "select_independent",
    "trim_heap",
    "usable_cores",
]
