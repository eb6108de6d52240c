"""An open mesh's holes, kept: their rims as feature curves, and caps that close them.

``MeshSurface(mesh, holes="keep")`` closes each hole of an open mesh with a
cap (CGAL's ``triangulate_hole_polyline`` over its rim), so that the fast
closed-mesh oracle applies (the angle-weighted pseudo-normal's sign, exact
crossings, the Lipschitz clearing), and protects each rim as a feature curve
(source :data:`RIM_SOURCE`). The remesh of the capped mesh then has an edge
chain along every rim, and :mod:`rdmesh.refine.hole_cut` cuts the caps' part
off along those chains. A hole whose cap would cross the mesh, or whose cap
lies on the mesh (an open sheet: its rim's cap is the sheet's flat twin), is
closed by a tent instead (:mod:`._mesh_tents`: a dome over the rim, leaving it
square to the faces on it), and where no tent clears the mesh either, by the
winding number's patch, which the cut tells apart from the faces by its
facets' distance to them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._errors import MeshInputError
from .._vectors import row_norms, unique_rows
from ..core import _rdt as core
from ..features.sharp_edges import chain_edges
from ._mesh_input import bounding_sphere, signed_volume
from ._mesh_repair import is_flat
from ._mesh_tents import TENT_HEIGHTS, faces_along_normal, input_clearance, rim_frame, tent

#: Where the feature curves come from: the rims (boundaries of a mesh with holes kept).
RIM_SOURCE = "hole rim"
#: A rim turning by at least this many degrees at a vertex has a corner there
#: (a curve's balls cannot shrink around a sharp turn without one).
RIM_TURN = 60.0
#: Rim edges under this fraction of the median rim edge are steps that the
#: rims' feature curves skip (:func:`_without_steps`).
RIM_STEP = 0.1
#: ``holes=`` choices of :class:`~rdmesh.MeshSurface`.
HOLES = ("keep", "fill")


@dataclass
class Holes:
    """The holes of an open mesh, as :class:`~rdmesh.MeshSurface` keeps them.

    Attributes
    ----------
    rims : list of (k,) int64
        Each rim's vertices in the order of its faces' half-edges.
    curves : list of (k, 3) float64
        The rims as polylines, split at corners (turns of :data:`RIM_TURN` or
        more); a closed loop repeats its first point.
    caps : (c, 3) int64
        Triangles over the rims, oriented as the faces; vertex ids from
        ``base`` are the tents' vertices.
    cap_rim : (c,) int64
        The rim each cap triangle closes.
    thirds : list of (k,) int64
        For each rim, the third vertex of the face on each of its edges.
    base : int
        The input's vertex count: ``apexes[j]`` is vertex ``base + j``.
    apexes : (t, 3) float64
        The tents' vertices (:func:`~._mesh_tents.tent`).
    apex_rim : (t,) int64
        The rim each of them closes.
    tries : (r,) int64
        How many tents each rim has tried.
    clearance : (cKDTree, float) or None
        With tents, :func:`~._mesh_tents.input_clearance` of the input.
    trimmed : (int, int)
        The input's faces dropped and added at its rims' slivers (:func:`trim_rims`).
    """

    rims: list[np.ndarray]
    curves: list[np.ndarray]
    caps: np.ndarray
    cap_rim: np.ndarray
    thirds: list[np.ndarray] = field(default_factory=list)
    base: int = 0
    apexes: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    apex_rim: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    tries: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    clearance: tuple | None = None
    trimmed: tuple[int, int] = (0, 0)

    @property
    def capless(self) -> np.ndarray:
        """The rims with neither cap nor tent (closed by the winding number)."""
        return np.setdiff1d(np.arange(len(self.rims)), self.cap_rim)

    def drop_caps(self, faces: np.ndarray) -> int:
        """Forget the caps (and tents) of the rims that the cap triangles ``faces``
        (indices into ``caps``) close; how many rims lost their cap."""
        return self.drop_rims(np.unique(self.cap_rim[faces]))

    def drop_rims(self, rims: np.ndarray) -> int:
        """Forget the caps (and tents) of ``rims``; how many there were."""
        keep = ~np.isin(self.cap_rim, rims)
        stay = ~np.isin(self.apex_rim, rims)
        # Tent vertex ids shift down over those dropped before them.
        new_id = (
            np.arange(self.base + len(stay)) - np.r_[np.zeros(self.base, int), np.cumsum(~stay)]
        )
        self.caps, self.cap_rim = new_id[self.caps[keep]], self.cap_rim[keep]
        self.apexes, self.apex_rim = self.apexes[stay], self.apex_rim[stay]
        return len(rims)

    def add_tents(self, vertices: np.ndarray, rims: np.ndarray) -> None:
        """Close each of ``rims`` (without caps) by its :func:`tent` at the next of
        :data:`TENT_HEIGHTS` (``tries`` counts them)."""
        apexes, apex_rim, caps, cap_rim = (
            [self.apexes],
            [self.apex_rim],
            [self.caps],
            [self.cap_rim],
        )
        first = self.base + len(self.apexes)
        for r in rims.tolist():
            new, tri = tent(
                vertices, self.rims[r], self.thirds[r], first, TENT_HEIGHTS[self.tries[r]]
            )
            self.tries[r] += 1
            first += len(new)
            apexes.append(new)
            apex_rim.append(np.full(len(new), r))
            caps.append(tri)
            cap_rim.append(np.full(len(tri), r))
        self.apexes, self.apex_rim = np.concatenate(apexes), np.concatenate(apex_rim)
        self.caps, self.cap_rim = np.concatenate(caps), np.concatenate(cap_rim)

    def largest_rim(self, vertices: np.ndarray) -> int:
        """The rim enclosing the largest area (by its vector area)."""
        return int(np.argmax([rim_frame(vertices, r)[2] for r in self.rims]))


def rim_half_edges(faces: np.ndarray) -> np.ndarray:
    """``(k, 4)``: the half-edges ``(a, b)`` of faces whose edge no other face
    has, with the face's third vertex ``c`` and the face's index."""
    m = len(faces)
    h = np.concatenate([faces[:, [0, 1, 2]], faces[:, [1, 2, 0]], faces[:, [2, 0, 1]]])
    h = np.c_[h, np.tile(np.arange(m), 3)]
    n = int(faces.max()) + 1
    key = np.minimum(h[:, 0], h[:, 1]) * n + np.maximum(h[:, 0], h[:, 1])
    order = np.argsort(key, kind="stable")
    k = key[order]
    once = np.r_[True, k[1:] != k[:-1]] & np.r_[k[1:] != k[:-1], True]
    return h[order[once]]


#: A rim that turns back on itself at a vertex, its two edges less than this
#: many degrees apart (a marching-cubes sliver at a cut), cannot be protected:
#: the balls of the curves on either side would have to shrink to nothing.
RIM_SLIVER = 10.0
#: Rounds of trimming at most (each trims slivers whose neighbours are not).
TRIM_ROUNDS = 8


def trim_rims(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray, int, int]:
    """The mesh with its rims' slivers trimmed: where two rim edges meet at less
    than :data:`RIM_SLIVER` degrees, the face holding both (a spike) is dropped,
    or, where no face does (a notch), the face across them is added, or where
    that face's third edge is in two faces already (a flap), the two faces on
    the rim edges are dropped. Returns ``(v, f, dropped, added)``, without the
    vertices no face uses any more."""
    dropped = added = 0
    for _ in range(TRIM_ROUNDS):
        h = rim_half_edges(f)
        if len(h) == 0 or len(np.unique(h[:, 0])) < len(h):
            break  # closed, or a rim that touches itself
        n = len(v)
        nxt, third, face, prv, face_in = (np.full(n, -1, np.int64) for _ in range(5))
        nxt[h[:, 0]], third[h[:, 0]], face[h[:, 0]] = h[:, 1], h[:, 2], h[:, 3]
        prv[h[:, 1]], face_in[h[:, 1]] = h[:, 0], h[:, 3]
        x = h[:, 0]
        p, q = prv[x], nxt[x]
        ok = (p >= 0) & (p != q)
        a, b = v[p] - v[x], v[q] - v[x]
        cos = np.einsum("ij,ij->i", a, b) / np.maximum(
            np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-300
        )
        sliver = np.zeros(n, bool)
        sliver[x] = ok & (cos > np.cos(np.radians(RIM_SLIVER)))
        # Not two neighbours in one round: a sliver goes first unless a
        # neighbour with a smaller index is one too.
        pp, qq = np.maximum(p, 0), np.maximum(q, 0)
        act = x[sliver[x] & ~(sliver[pp] & (pp < x)) & ~(sliver[qq] & (qq < x))]
        if len(act) == 0:
            break
        ear = third[act] == prv[act]
        notch = act[~ear]
        count = _edge_count(f, prv[notch], nxt[notch])
        flap, notch = notch[count >= 2], notch[count < 2]
        keep = np.ones(len(f), bool)
        keep[face[act[ear]]] = False
        keep[face[flap]] = keep[face_in[flap]] = False
        dropped += int(np.count_nonzero(~keep))
        f = np.concatenate([f[keep], np.c_[notch, prv[notch], nxt[notch]]])
        added += len(notch)
        if not len(f):
            break
    if not dropped:
        return v, f, 0, added
    used, f = np.unique(f, return_inverse=True)
    return v[used], f.reshape(-1, 3).astype(np.int64), dropped, added


def drop_pinch_fans(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """The mesh without the smaller fans at pinched rim vertices: where rims
    touch at a point (a vertex split in copies, one per fan of faces, by
    :func:`~._mesh_input.split_pinches`), the faces of every copy but the one
    with the most are dropped, so that the rims part there (the balls
    protecting two rims through one point would have to shrink to nothing,
    and what closes the holes would touch itself there). Returns ``(v, f,
    dropped)``, without the vertices no face uses any more."""
    _, inverse = unique_rows(v)
    on_rim = np.zeros(len(v), bool)
    on_rim[rim_half_edges(f)[:, :2]] = True
    ids = np.flatnonzero(on_rim & (np.bincount(inverse)[inverse] > 1))
    if not len(ids):
        return v, f, 0
    faces_at = np.bincount(f.reshape(-1), minlength=len(v))
    # Per point, the copy with the most faces (then the lowest id) stays.
    order = ids[np.lexsort((ids, -faces_at[ids], inverse[ids]))]
    first = np.r_[True, inverse[order[1:]] != inverse[order[:-1]]]
    gone = np.zeros(len(v), bool)
    gone[order[~first]] = True
    keep = ~gone[f].any(axis=1)
    used, f = np.unique(f[keep], return_inverse=True)
    return v[used], f.reshape(-1, 3).astype(np.int64), int(np.count_nonzero(~keep))


def _edge_count(f: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """How many faces of ``f`` have the edge ``(a_i, b_i)``, either way."""
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    n = int(max(f.max(initial=0), a.max(initial=0), b.max(initial=0))) + 1
    key = np.sort(e[:, 0] * n + e[:, 1])
    q = np.minimum(a, b) * n + np.maximum(a, b)
    return np.searchsorted(key, q, "right") - np.searchsorted(key, q, "left")


def rim_loops(half: np.ndarray) -> list[np.ndarray]:
    """The rims as vertex loops, following the half-edges ``(a, b)``; None when a
    vertex starts other than one rim half-edge (a rim that touches itself or
    inconsistently oriented faces)."""
    starts, counts = np.unique(half[:, 0], return_counts=True)
    if len(half) == 0 or counts.max() > 1 or not np.array_equal(np.sort(half[:, 1]), starts):
        return None
    nxt = dict(zip(half[:, 0].tolist(), half[:, 1].tolist(), strict=True))
    loops, seen = [], set()
    for a in half[:, 0].tolist():
        if a in seen:
            continue
        loop = [a]
        seen.add(a)
        b = nxt[a]
        while b != a:
            loop.append(b)
            seen.add(b)
            b = nxt[b]
        loops.append(np.array(loop, np.int64))
    return loops


def cap(vertices: np.ndarray, loop: np.ndarray, third: np.ndarray) -> np.ndarray:
    """Triangles over one rim (vertex ids), oriented against the rim's half-edges
    (so that the cap's edges pair with the faces'), meeting the faces on the rim
    (``third``: their third vertices, one per rim edge) at the flattest angles
    (Liepa's weight; a least-area cap can fold back through faces next to the
    rim); empty when CGAL finds none."""
    tri = core.fill_hole(vertices[loop], vertices[third])
    if len(tri) == 0:
        return np.zeros((0, 3), np.int64)
    t = loop[tri]
    # The face has (a, b); the cap must have (b, a).
    a, b = loop[0], loop[1]
    h = np.stack([t, np.roll(t, -1, axis=1)], axis=2).reshape(-1, 2)
    same = np.any((h[:, 0] == a) & (h[:, 1] == b))
    return t[:, ::-1].copy() if same else t


def find_holes(vertices: np.ndarray, faces: np.ndarray) -> Holes | None:
    """The holes of a mesh (None when it has none); ``caps`` empty when a rim
    cannot be followed or a hole cannot be triangulated."""
    half = rim_half_edges(faces)
    if len(half) == 0:
        return None
    loops = rim_loops(half[:, :2])
    edges = half[:, :2] if loops is None else _without_steps(vertices, loops)
    chains, closed = chain_edges(vertices, np.sort(edges, axis=1), RIM_TURN)
    curves = [
        vertices[np.r_[c, c[:1]]] if cl else vertices[c]
        for c, cl in zip(chains, closed, strict=True)
    ]
    if loops is None:
        return Holes([], curves, np.zeros((0, 3), np.int64), np.zeros(0, np.int64))
    third = np.full(len(vertices), -1, np.int64)
    third[half[:, 0]] = half[:, 2]  # of the rim edge (a, b), by a
    caps = [cap(vertices, loop, third[loop]) for loop in loops]
    rim = np.concatenate([np.full(len(c), k) for k, c in enumerate(caps)]).astype(np.int64)
    thirds = [third[loop] for loop in loops]
    return Holes(loops, curves, np.concatenate(caps), rim, thirds, base=len(vertices))


def _without_steps(vertices: np.ndarray, loops: list[np.ndarray]) -> np.ndarray:
    """The rims' edges ``(k, 2)`` for their feature curves, tiny steps left out:
    a vertex entered by an edge under :data:`RIM_STEP` times the median rim
    edge is skipped, while the run of such edges it ends stays that short (a
    marching-cubes rim's steps would otherwise need balls smaller than the
    step, two corners a tiny edge apart). The curves stray from the rims by
    less than the run."""
    lengths = [row_norms(vertices[np.roll(loop, -1)] - vertices[loop]) for loop in loops]
    short = RIM_STEP * float(np.median(np.concatenate(lengths)))
    out = []
    for loop, length in zip(loops, lengths, strict=True):
        # Edge i runs from loop[i] to loop[i + 1]; vertex 0 is always kept.
        tiny = np.r_[False, length[:-1] < short]
        start = np.flatnonzero(~tiny)
        run = np.cumsum(~tiny) - 1
        walked = np.cumsum(np.r_[0.0, length[:-1]] * tiny)
        keep = loop[~(tiny & (walked - walked[start[run]] <= short))]
        if len(keep) < 3:
            keep = loop
        out.append(np.c_[keep, np.roll(keep, -1)])
    return np.concatenate(out)


def with_caps(
    f: np.ndarray, norms: np.ndarray, normals: np.ndarray, v: np.ndarray, holes: Holes | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The faces, their doubled areas and unit normals with the caps appended,
    all turned so that the (closed) mesh's signed volume is positive."""
    if holes is None or not len(holes.caps):
        return f, norms, normals
    c = holes.caps
    area = np.cross(v[c[:, 1]] - v[c[:, 0]], v[c[:, 2]] - v[c[:, 0]])
    cn = np.linalg.norm(area, axis=1)
    f = np.concatenate([f, c])
    norms = np.concatenate([norms, cn])
    normals = np.concatenate([normals, area / np.where(cn > 0, cn, 1.0)[:, None]])
    if signed_volume(v, f) < 0:
        f, normals = f[:, ::-1].copy(), -normals
    return f, norms, normals


def close_holes(surface, norms: np.ndarray, sphere: tuple[np.ndarray, float]):
    """Append the caps over ``surface.holes`` to ``surface.faces`` (and the tents'
    vertices to ``surface.vertices``) and build its queries (``_start_queries``);
    returns the faces' doubled areas and the bounding ``sphere`` (centre, radius)
    of the input, widened over the tents.

    A cap that crosses the mesh or shares an edge with it is dropped (of two
    caps that cross, the smaller rim's), and so is the largest rim's cap when
    the capped mesh encloses no volume (an open sheet). Those holes get a
    :func:`~._mesh_tents.tent` instead, at the first of :data:`TENT_HEIGHTS` whose tent
    crosses nothing; the holes that none clears are closed by the winding
    number's patches.

    Raises
    ------
    rdmesh.MeshInputError
        The closed mesh still encloses no volume.
    """
    holes, radius = surface.holes, sphere[1]
    if holes is None or not holes.rims:
        surface._start_queries(radius)
        return norms, sphere
    v, inputs = surface.vertices, (surface.faces, norms, surface._normals)
    n = len(inputs[0])

    def build() -> tuple[np.ndarray, np.ndarray]:
        """Close the mesh with the holes' caps; the rims whose caps cross something."""
        surface.vertices = np.concatenate([v, holes.apexes]) if len(holes.apexes) else v
        surface.faces, area, surface._normals = with_caps(*inputs, surface.vertices, holes)
        surface._start_queries(radius)
        pairs = surface._core.self_intersections().reshape(-1, 2)
        return area, _crossing_rims(holes, np.sort(pairs, axis=1) - n, rim_size)

    rim_size = np.array([row_norms(v[np.roll(r, -1)] - v[r]).sum() for r in holes.rims])

    if len(holes.caps):
        # A cap edge that is already an edge of the mesh (a neck between two
        # rim vertices) would be in three faces: that hole keeps no cap.
        holes.drop_caps(_overfull(np.concatenate([inputs[0], holes.caps]), n))
    holes.tries = np.zeros(len(holes.rims), np.int64)
    for r, (loop, third) in enumerate(zip(holes.rims, holes.thirds, strict=True)):
        if not faces_along_normal(v, loop, third):
            holes.tries[r] = len(TENT_HEIGHTS)  # no tent: it would lie along them
    flat_seen = False
    while True:
        todo = holes.capless
        # Crossings are found on closed meshes only: once a rim has no tent
        # left to try, no other tent can be tested either.
        if len(todo) and (holes.tries[todo] >= len(TENT_HEIGHTS)).any():
            area, _ = build()
            break
        holes.add_tents(v, todo)
        area, crossing = build()
        if holes.drop_rims(crossing):
            continue
        if flat_seen or not _encloses_nothing(surface, area, n):
            break
        flat_seen = True  # an open sheet: its largest rim's cap lies on it
        holes.drop_rims(np.array([holes.largest_rim(v)]))
    if _encloses_nothing(surface, area, n):
        raise MeshInputError(
            "the mesh is too open to tell inside from outside: closed over its "
            f"{len(holes.rims)} holes it encloses no volume (a flat patch?)"
        )
    if len(holes.apexes):  # tents stand off the input
        holes.clearance = input_clearance(v, inputs[0])
        sphere = bounding_sphere(surface.vertices)
        surface.cap *= sphere[1] / radius  # the distance cap scales with the radius
    return area, sphere


def _crossing_rims(holes: Holes, pairs, size: np.ndarray) -> np.ndarray:
    """The rims to uncap for the crossing face ``pairs`` ``(k, 2)`` (cap triangles
    from 0, the input's faces negative): a cap crossing the input, and of two
    caps crossing, the smaller rim's (its length ``size``), so that a scan's
    specks do not uncap its outer rim."""
    pairs = pairs[pairs[:, 1] >= 0]  # not two of the input's faces
    if not len(pairs):
        return np.zeros(0, np.int64)
    rim = np.where(pairs >= 0, holes.cap_rim[np.maximum(pairs, 0)], -1)
    other = pairs[:, 0] >= 0
    smaller = np.where(size[rim[:, 0]] <= size[rim[:, 1]], rim[:, 0], rim[:, 1])
    return np.unique(np.where(other, smaller, rim[:, 1]))


def _encloses_nothing(surface, area: np.ndarray, n: int) -> bool:
    """Whether the mesh closed by caps (``surface.faces`` beyond ``n``) is flat."""
    if len(surface.faces) == n:
        return False
    volume = signed_volume(surface.vertices, surface.faces)  # with_caps turned them out
    return bool(is_flat(volume, 0.5 * float(area.sum())))


def _overfull(f: np.ndarray, n: int) -> np.ndarray:
    """Indices (from ``n``) of the faces ``f[n:]`` with an edge in more than two faces."""
    c = f[n:]
    count = _edge_count(f, c.reshape(-1), c[:, [1, 2, 0]].reshape(-1)).reshape(-1, 3)
    return np.flatnonzero((count > 2).any(axis=1))


#: A facet's surface centre farther than this (times R) from the input's faces
#: lies on a winding-number patch (input facets' centres are crossings of faces).
OFF_INPUT = 1e-7


def on_caps(surface, centres: np.ndarray) -> np.ndarray:
    """``(k,)`` bool: which facets of a remesh of ``surface`` (a mesh with its holes
    kept) lie on what closes a hole, by their surface centres ``(k, 3)``: on a cap
    face, or (winding-number patches) off the input's faces."""
    centres = np.ascontiguousarray(centres, np.float64).reshape(-1, 3)
    # Exact crossings: the face they were found on; the rest are queried.
    face = surface.crossing_faces(centres)
    off = np.zeros(len(centres), bool)
    rest = np.flatnonzero(face < 0)
    if len(rest):
        dist, _, face[rest], _ = surface._core.query(centres[rest])
        off[rest] = dist > OFF_INPUT * surface.radius
    return (face >= surface.input_face_count) | off
