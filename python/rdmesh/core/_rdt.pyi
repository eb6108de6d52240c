# Type stub of rdmesh._rdt, the C++ core (cpp/module.cpp and the bind_*.cpp files
# it lists).  Kept in step with the bindings by
# tests/test_core_threads.py::test_stub_matches_the_bindings.

from typing import Final

import numpy as np
import numpy.typing as npt

CGAL_VERSION: Final[str]
RESTRICTED: Final[int]
BAD: Final[int]
OUTWARD: Final[int]
TOPO: Final[int]
KNOWN: Final[int]
INTERVAL_OPS: Final[dict[str, int]]  # opcode of each interval instruction, by name
INTERVAL_REL_WIDENING: Final[float]

_SegmentSamples = tuple[
    npt.NDArray[np.int64],  # (k+1,) offsets
    npt.NDArray[np.float64],  # (P,) distances from each segment's start
    npt.NDArray[np.float64],  # (P - 2k, 3) interior points
]

def sample_segments(
    seg: npt.ArrayLike,
    apex: npt.ArrayLike,
    rho: npt.ArrayLike,
    per_radius: float = 1.0,
    min_intervals: int = 3,
    max_intervals: int = 64,
) -> _SegmentSamples: ...
def boxes_outside_cells(
    lo: npt.ArrayLike,
    hi: npt.ArrayLike,
    owner: npt.ArrayLike,
    points: npt.ArrayLike,
    offsets: npt.ArrayLike,
    neighbour: npt.ArrayLike,
    skip: npt.ArrayLike | None = None,
) -> npt.NDArray[np.uint8]: ...
def isolate_segment_roots(
    ops: npt.ArrayLike,
    consts: npt.ArrayLike,
    a: npt.ArrayLike,
    b: npt.ArrayLike,
    min_length: float,
    budget: int = 65536,
    t0: npt.ArrayLike | None = None,
    t1: npt.ArrayLike | None = None,
) -> tuple[
    npt.NDArray[np.int64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.int64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    int,
]: ...
def prove_boxes(
    ops: npt.ArrayLike,
    consts: npt.ArrayLike,
    lo: npt.ArrayLike,
    hi: npt.ArrayLike,
    cell: npt.ArrayLike,
    direction: npt.ArrayLike,
    floor: npt.ArrayLike,
    points: npt.ArrayLike,
    offsets: npt.ArrayLike,
    neighbour: npt.ArrayLike,
    skip: npt.ArrayLike | None = None,
    plane: npt.ArrayLike | None = None,
    budget: int = 65536,
    leaves: bool = False,
    seeds: tuple[npt.ArrayLike, npt.ArrayLike, npt.ArrayLike, npt.ArrayLike] | None = None,
) -> tuple: ...  # (failed, lo, hi, boxes), then (leaf_first, leaf_lo, leaf_hi) with leaves
def segment_pieces(
    a: npt.ArrayLike,
    b: npt.ArrayLike,
    host: npt.ArrayLike,
    first: npt.ArrayLike,
    lo: npt.ArrayLike,
    hi: npt.ArrayLike,
    slack: float,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def evaluate_intervals(
    ops: npt.ArrayLike,
    consts: npt.ArrayLike,
    lo: npt.ArrayLike,
    hi: npt.ArrayLike,
    gradient: bool,
    mean_value: bool,
) -> tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64] | None,
    npt.NDArray[np.float64] | None,
    npt.NDArray[np.uint8],
]: ...
def scan_samples(
    offsets: npt.ArrayLike,
    s: npt.ArrayLike,
    values: npt.ArrayLike,
    ends: npt.ArrayLike | None = None,
    dip_fraction: float = 0.25,
) -> tuple[
    tuple[
        npt.NDArray[np.int64],
        npt.NDArray[np.float64],
        npt.NDArray[np.float64],
        npt.NDArray[np.uint8],
        npt.NDArray[np.float64],
        npt.NDArray[np.float64],
    ],  # sign changes: seg, lo, hi, rising, f at lo, f at hi
    tuple[
        npt.NDArray[np.int64],
        npt.NDArray[np.float64],
        npt.NDArray[np.float64],
        npt.NDArray[np.float64],
        npt.NDArray[np.float64],
    ],  # dips: seg, x1, x2, x3, sign
    tuple[
        npt.NDArray[np.int64],
        npt.NDArray[np.float64],
        npt.NDArray[np.float64],
        npt.NDArray[np.uint8],
        npt.NDArray[np.float64],
        npt.NDArray[np.float64],
    ],  # valleys: seg, lo, hi, inside, |f| lo, |f| hi
]: ...
def complex_status(
    faces: npt.ArrayLike, n_vertices: int
) -> tuple[
    npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int32], npt.NDArray[np.int64]
]: ...
def select_independent(centres: npt.ArrayLike, radii: npt.ArrayLike) -> npt.NDArray[np.int64]: ...
def trim_heap() -> bool: ...
def fill_hole(
    points: npt.ArrayLike, third: npt.ArrayLike | None = None
) -> npt.NDArray[np.int64]: ...
def _fail_allocation_for_testing(n: int) -> int: ...
def _fail_worker_for_testing(n: int) -> int: ...
def usable_cores() -> int: ...

class MeshDistance:
    def __init__(
        self,
        vertices: npt.ArrayLike,
        faces: npt.ArrayLike,
        side: bool = True,
        winding: bool = True,
    ) -> None: ...
    def query(
        self, points: npt.ArrayLike
    ) -> tuple[
        npt.NDArray[np.float64],  # (k,) distances
        npt.NDArray[np.float64],  # (k, 3) closest points
        npt.NDArray[np.int64],  # (k,) faces of the closest points
        npt.NDArray[np.int8],  # (k,) sides: +1 outside, -1 inside, 0 on or unknown
    ]: ...
    def side(self, points: npt.ArrayLike) -> npt.NDArray[np.int8]: ...
    def winding_number(
        self, points: npt.ArrayLike, beta: float = 2.5
    ) -> npt.NDArray[np.float64]: ...
    def segment_hits(
        self, segments: npt.ArrayLike
    ) -> tuple[
        npt.NDArray[np.int64],  # (m,) segment of each hit
        npt.NDArray[np.float64],  # (m,) t in [0, 1], NaN when ill-conditioned
        npt.NDArray[np.int64],  # (m,) face hit
    ]: ...
    def self_intersections(self) -> npt.NDArray[np.int64]: ...  # (k, 2) face pairs
    @property
    def has_side(self) -> bool: ...
    @property
    def has_pseudo_normals(self) -> bool: ...
    @property
    def side_failure(self) -> str: ...
    @property
    def number_of_faces(self) -> int: ...

class PointMap:  # exact points -> ids, the smallest id kept per point (thread-safe)
    def __init__(self) -> None: ...
    def add(self, points: npt.ArrayLike, ids: npt.ArrayLike) -> None: ...
    def get(self, points: npt.ArrayLike) -> npt.NDArray[np.int64]: ...  # -1: not held
    def clear(self) -> None: ...
    @property
    def size(self) -> int: ...

class RestrictedDelaunay:
    def __init__(self, centre: npt.ArrayLike, radius: float) -> None: ...
    def set_clip_box(self, lo: npt.ArrayLike, hi: npt.ArrayLike) -> None: ...
    @property
    def has_clip_box(self) -> bool: ...
    def insert(
        self, points: npt.ArrayLike, weights: npt.ArrayLike | None = None
    ) -> npt.NDArray[np.int64]: ...
    def changed_facets(
        self,
        max_facets: int = 0,
        per_radius: float = 1.0,
        min_intervals: int = 3,
        max_intervals: int = 64,
    ) -> tuple[
        npt.NDArray[np.int64],  # (k, 3) sorted vertex ids
        npt.NDArray[np.float64],  # (k, 2, 3) clipped dual segments
        npt.NDArray[np.int64],  # (k, 2) indices of the segment ends into ...
        npt.NDArray[np.float64],  # ... (u, 3) distinct end points
        npt.NDArray[np.float64],  # (k,) facet circumradii
        _SegmentSamples,
        npt.NDArray[np.float64],  # (u,) f at the ends kept by the core, NaN elsewhere
        npt.NDArray[np.int64],  # (u,) index among the previous call's ends, or -1
    ]: ...
    def update_facets(
        self, flags: npt.ArrayLike, centres: npt.ArrayLike, end_f: npt.ArrayLike | None = None
    ) -> None: ...
    def restart_round(self) -> None: ...
    def facets(
        self, mask: int = 0
    ) -> tuple[
        npt.NDArray[np.int64],  # (k, 3) outward-oriented vertex ids
        npt.NDArray[np.float64],  # (k, 3) surface centres
        npt.NDArray[np.uint8],  # (k,) flag bits
    ]: ...
    def facets_around(
        self, ids: npt.ArrayLike
    ) -> tuple[
        npt.NDArray[np.int64],  # (k, 3) outward-oriented vertex ids
        npt.NDArray[np.float64],  # (k, 3) surface centres
        npt.NDArray[np.uint8],  # (k,) flag bits
    ]: ...
    def take_touched(self) -> npt.NDArray[np.int64]: ...
    def all_facets(
        self,
    ) -> tuple[
        npt.NDArray[np.int64],  # (k, 3) sorted vertex ids
        npt.NDArray[np.float64],  # (k, 2, 3) clipped dual segments
    ]: ...
    def is_facet(self, tri: npt.ArrayLike) -> npt.NDArray[np.bool_]: ...
    def neighbours(
        self, ids: npt.ArrayLike
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]: ...
    def voronoi_facets(
        self, edges: npt.ArrayLike
    ) -> tuple[
        npt.NDArray[np.int64],  # (m+1,) offsets
        npt.NDArray[np.float64],  # (T, 3) polygon vertices
        npt.NDArray[np.int64],  # (T,) distinct-cell index of each vertex
        npt.NDArray[np.int64],  # (T,) third vertex of each dual facet, -1: dummy
    ]: ...
    def star_cells(
        self, ids: npt.ArrayLike
    ) -> tuple[
        npt.NDArray[np.int64],  # (c, 4) sorted vertex ids, -1: dummy
        npt.NDArray[np.float64],  # (c, 3) circumcentres
    ]: ...
    def relabel_stars(
        self,
        faces: npt.ArrayLike,
        ids: npt.ArrayLike,
        cells: npt.ArrayLike,
        cost: npt.ArrayLike,
        max_seconds: float | None = None,
    ) -> tuple[
        npt.NDArray[np.int64],  # (k, 3) outward faces
        npt.NDArray[np.int64],  # (m, 4) sorted ids of the cells moved
        bool,  # max_seconds cut it short
    ]: ...
    def voronoi_boxes(
        self,
    ) -> tuple[
        npt.NDArray[np.int64],  # (m, 2) every Delaunay edge between samples
        npt.NDArray[np.float64],  # (m, 2, 3) the bounding box of its Voronoi facet
        npt.NDArray[np.float64],  # (samples, 2, 3) every sample's Voronoi cell box
    ]: ...
    def voronoi_cell_boxes(self, ids: npt.ArrayLike) -> npt.NDArray[np.float64]: ...
    def delaunay_edges(self, ids: npt.ArrayLike | None = None) -> npt.NDArray[np.int64]: ...
    def samples(self) -> npt.NDArray[np.float64]: ...
    def weights(self) -> npt.NDArray[np.float64]: ...
    @property
    def number_of_samples(self) -> int: ...
    @property
    def number_of_cells(self) -> int: ...
    @property
    def reused_facets(self) -> int: ...
    def set_clearing(
        self, f: GridField, slopes: GridField, scale: float, reach: float, cap: float
    ) -> None: ...
    def set_clearing_cap(self, cap: float) -> None: ...
    def set_fine_clearing(self, m: int, threshold: int, reach: float) -> None: ...
    def grid_clears(self, seg: npt.ArrayLike) -> npt.NDArray[np.bool_]: ...
    def take_hot_nodes(self) -> npt.NDArray[np.int64]: ...
    def fine_points(self, nodes: npt.ArrayLike) -> npt.NDArray[np.float64]: ...
    def fill_fine(
        self, nodes: npt.ArrayLike, values: npt.ArrayLike, bounds: npt.ArrayLike
    ) -> None: ...
    @property
    def fine_clearing_stats(self) -> tuple[int, int]: ...
    @property
    def cleared_facets(self) -> int: ...
    @property
    def exact_circumcentres(self) -> int: ...
    def check(self) -> None: ...

class GridField:
    def __init__(
        self,
        values: npt.ArrayLike,
        centre: npt.ArrayLike,
        rotation: npt.ArrayLike,
        offset: npt.ArrayLike,
        h: float,
    ) -> None: ...
    def at(self, points: npt.ArrayLike) -> npt.NDArray[np.float64]: ...
    def raise_to(self, points: npt.ArrayLike, values: npt.ArrayLike, cells: int) -> None: ...
    def segment_bounds(
        self, seg: npt.ArrayLike, reach: float, scale: float, cap: float
    ) -> npt.NDArray[np.float64]: ...
    def clearing_values(
        self, seg: npt.ArrayLike, bound: npt.ArrayLike
    ) -> npt.NDArray[np.float64]: ...
    @property
    def values(self) -> npt.NDArray[np.float64]: ...

class VolumeSampler:
    def __init__(
        self,
        coefficients: npt.ArrayLike,
        degree: int,
        origin: npt.ArrayLike,
        spacing: npt.ArrayLike,
    ) -> None: ...
    def sample(
        self, points: npt.ArrayLike, gradient: bool = False
    ) -> tuple[
        npt.NDArray[np.float64],  # (n,) values
        npt.NDArray[np.float64] | None,  # (n, 3) gradients, if asked
    ]: ...
    def coefficients(self) -> npt.NDArray[np.float64]: ...  # (n0, n1, n2) copy
    @property
    def degree(self) -> int: ...
    @property
    def shape(self) -> tuple[int, int, int]: ...
