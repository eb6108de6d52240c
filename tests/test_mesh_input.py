"""MeshSurface on real-data problems (issue 30): the pseudo-normal sign,
self-intersecting input, and the time limit's message."""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
from child import run_python
from hypothesis import given, settings
from hypothesis import strategies as st
from rdmesh.core import MeshDistance
from rdmesh.refine.mesher import Budget

measure = pytest.importorskip("skimage.measure")


def mc_mesh(f, lo: float, hi: float, n: int = 48) -> tuple[np.ndarray, np.ndarray]:
    """Marching cubes of ``f < 0`` on an ``n``-per-axis grid, outward faces."""
    ax = np.linspace(lo, hi, n)
    pts = np.stack(np.meshgrid(ax, ax, ax, indexing="ij"), -1).reshape(-1, 3)
    v, faces, _, _ = measure.marching_cubes(
        f(pts).reshape(n, n, n), 0.0, spacing=(ax[1] - ax[0],) * 3
    )
    return v + lo, faces.astype(np.int64)


def torus_f(p):
    x, y, z = p.T
    return (x * x + y * y + z * z + 1 - 0.16) ** 2 - 4 * (x * x + y * y)


def sphere_mesh(centre, radius, n=32):
    v, f = mc_mesh(lambda p: np.linalg.norm(p, axis=1) - radius, -1.3 * radius, 1.3 * radius, n)
    return v + np.asarray(centre, float), f


@pytest.mark.parametrize("outward", [True, False])
def test_pseudo_normal_sign_equals_ray_casting(outward):
    v, f = mc_mesh(torus_f, -1.6, 1.6, 40)
    f = f if outward else f[:, ::-1].copy()
    core = MeshDistance(v, f, side=True)
    assert core.has_side
    # Inward faces: the pseudo-normals would flip every sign; ray casting stays.
    assert core.has_pseudo_normals == outward
    rng = np.random.default_rng(0)
    near = v[rng.integers(0, len(v), 20000)] + rng.normal(scale=1e-3, size=(20000, 3))
    # Points right above vertices and edge midpoints (closest feature a vertex or an edge).
    normals = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    mid = 0.5 * (v[f[:, 0]] + v[f[:, 1]])
    offsets = (
        rng.choice([-1e-4, 1e-4], size=(len(f), 1))
        * normals
        / np.linalg.norm(normals, axis=1, keepdims=True)
    )
    far = rng.uniform(-1.6, 1.6, (5000, 3))
    q = np.concatenate([near, mid + offsets, v + 1e-4 * rng.normal(size=v.shape), far])
    _, _, _, side = core.query(q)
    assert np.array_equal(side, core.side(q))
    assert np.count_nonzero(side == -1) > 1000 and np.count_nonzero(side == 1) > 1000


def test_on_the_surface_is_zero():
    v, f = sphere_mesh((0, 0, 0), 1.0)
    core = MeshDistance(v, f, side=True)
    assert core.has_pseudo_normals
    assert np.all(core.query(v)[3] == 0)


def overlapping_spheres():
    a = sphere_mesh((0, 0, 0), 1.0)
    b = sphere_mesh((1.2, 0, 0), 1.0)
    return np.concatenate([a[0], b[0]]), np.concatenate([a[1], b[1] + len(a[0])])


def test_self_intersections_are_found_and_located():
    ms = rdmesh.MeshSurface(overlapping_spheres())
    pairs = ms.self_intersections
    assert pairs.shape[1] == 2 and len(pairs) > 10
    # The crossing faces lie on the circle where the spheres meet (x = 0.6).
    where = ms.vertices[ms.faces[pairs.ravel()]].mean(axis=1)
    assert np.all(np.abs(where[:, 0] - 0.6) < 0.2)
    assert ms.sign_method == "winding"


def test_a_closed_mesh_has_no_self_intersections():
    ms = rdmesh.MeshSurface(sphere_mesh((0, 0, 0), 1.0))
    assert ms._core.has_pseudo_normals
    assert len(ms.self_intersections) == 0
    assert ms.input_report() is None
    assert ms.input_report(np.zeros((0, 3))) is None
    assert ms.sign_method == "side"


def _touching_at_a_vertex():
    """Two spheres whose vertices at x = 1 coincide (merged when read): the
    surface touches itself at that point."""
    a, b = sphere_mesh((0, 0, 0), 1.0), sphere_mesh((2, 0, 0), 1.0)
    ia, ib = int(np.argmax(a[0][:, 0])), int(np.argmin(b[0][:, 0]))
    vb = b[0].copy()
    vb[ib] = a[0][ia]
    return np.concatenate([a[0], vb]), np.concatenate([a[1], b[1] + len(a[0])])


def test_pinched_vertices_are_split_one_copy_per_fan():
    from rdmesh.surfaces._mesh_input import clean, split_pinches

    v, f = _touching_at_a_vertex()
    merged_v, merged_f = clean(v, f)
    # The equal vertices were merged, and the pinch split again: as many
    # vertices as the input, each face on the same points.
    assert len(merged_v) == len(v)
    assert np.allclose(np.sort(merged_v[merged_f].reshape(-1, 9), axis=0),
                       np.sort(v[f].reshape(-1, 9), axis=0))  # fmt: skip
    # Each vertex's faces form one fan: every edge in two faces, V - E + F = 2 a component.
    edges = np.unique(np.sort(merged_f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
    assert len(merged_v) - len(edges) + len(merged_f) == 4
    unchanged = split_pinches(*sphere_mesh((0, 0, 0), 1.0))
    assert len(unchanged[0]) == len(sphere_mesh((0, 0, 0), 1.0)[0])


def test_a_surface_touching_itself_at_a_point_is_reported():
    ms = rdmesh.MeshSurface(_touching_at_a_vertex())
    # Split, the mesh is a closed manifold; CGAL finds the faces that touch.
    assert len(ms.self_intersections) > 0
    where = ms.vertices[ms.faces[ms.self_intersections.ravel()]].mean(axis=1)
    assert np.all(np.abs(where[:, 0] - 1.0) < 0.3)
    assert not ms.topology_known


def test_self_intersecting_input_is_remeshed_and_marked_incomplete():
    ms = rdmesh.MeshSurface(overlapping_spheres())
    mesh = rdmesh.mesh_surface(ms, radius_bound=0.15, distance_bound=0.015)
    assert not mesh.complete
    assert "intersects itself" in mesh.stats["stop_reason"]
    assert mesh.report["input"]["self_intersections"]["pairs"] == len(ms.self_intersections)
    assert "intersects itself" in mesh.report["statement"]
    # The best mesh it can: the union, one closed sphere-like component.
    assert mesh.report["components"] == 1 and mesh.report["euler"] == [2]
    assert mesh.report["closed_manifold"]


def test_time_limit_message_says_what_happened():
    b = Budget(time_limit=300.0)
    assert b.exceeded(10, 20.0, 5.0, 100) is None
    msg = b.exceeded(10, 290.0, 25.0, 4000)
    assert "stopped after 290.0s" in msg and "4000 points" in msg and "25.0s" in msg
    assert "after 301.0s" in b.exceeded(10, 301.0)
    # Building the mesh after the round counts too.
    assert b.exceeded(10, 270.0, 25.0, 4000) is None
    msg = b.exceeded(10, 270.0, 25.0, 4000, finish=8.0)
    assert "stopped after 270.0s" in msg and "8.0s to build the mesh" in msg


@given(
    st.floats(1.0, 100.0),
    st.floats(0.0, 1.0),
    st.integers(0, 10**6),
    st.floats(1e-6, 1e-3),
    st.integers(1, 10**6),
)
def test_a_partial_last_round_fits_in_the_time_left(limit, used, n, per_point, k):
    from rdmesh.refine.mesher import FINISH_SHARE, MIN_PARTIAL_ROUND, _fit

    seconds = used * limit
    ahead = (per_point * k, FINISH_SHARE * per_point * (n + k), per_point)
    fit = _fit(Budget(time_limit=limit), seconds, n, ahead, k)
    assert _fit(Budget(), seconds, n, ahead, k) == 0
    assert 0 <= fit < k
    if fit:
        # The part and the mesh's building after it end within the limit.
        assert seconds + per_point * fit + FINISH_SHARE * per_point * (n + fit) <= limit
        assert fit >= MIN_PARTIAL_ROUND[0] and fit >= MIN_PARTIAL_ROUND[1] * k


def test_a_run_past_its_time_ends_with_a_partial_round_and_says_so(monkeypatch):
    # As if each point cost 10 ms: the second round cannot end within the
    # limit, so it inserts the points that fit, the mesh's building included.
    from rdmesh.refine import mesher

    cost = 0.01

    def ahead(loop, last, done, n, k):
        if not done:
            return 0.0, 0.0, 0.0
        return cost * k, mesher.FINISH_SHARE * cost * (n + k), cost

    monkeypatch.setattr(mesher, "_ahead", ahead)
    monkeypatch.setattr(mesher, "MIN_PARTIAL_ROUND", (1, 0.0))
    sizes = []
    surface = rdmesh.surfaces.torus()
    with pytest.raises(rdmesh.BudgetExceeded, match="the last round inserted") as info:
        rdmesh.mesh_surface(
            surface,
            radius_bound=surface.radius / 100,
            time_limit=60.0,
            progress=lambda d: sizes.append(d["vertices"]),
        )
    assert len(sizes) == 2
    n, fit = sizes[0], sizes[1] - sizes[0]
    assert fit > 0 and cost * (fit + mesher.FINISH_SHARE * (n + fit)) <= 60.0
    assert f"inserted {fit} of its" in str(info.value)
    assert not info.value.mesh.complete


def test_other_budgets_get_no_partial_round(monkeypatch):
    # A round that would not fit in memory is not started, in part or whole,
    # however much time is left.
    from rdmesh.refine import mesher

    monkeypatch.setattr(mesher, "MIN_PARTIAL_ROUND", (1, 0.0))
    calls = []

    def shortfall(n, k):  # room for the first round only
        calls.append(n)
        return "memory: too little" if len(calls) > 1 else None

    monkeypatch.setattr(mesher, "shortfall", shortfall)
    sizes = []
    surface = rdmesh.surfaces.torus()
    with pytest.raises(rdmesh.BudgetExceeded, match="memory: too little"):
        rdmesh.mesh_surface(
            surface,
            radius_bound=surface.radius / 100,
            time_limit=1000.0,
            progress=lambda d: sizes.append(d["vertices"]),
        )
    assert len(sizes) == 1  # the round after the seeds' first was not started


def test_sheet_gap_measures_the_thinnest_part():
    # A slab 0.02 thick (a flat box of 12 triangles): the gap is its thickness.
    corners = np.array(
        [[x, y, z] for x in (-0.8, 0.8) for y in (-0.8, 0.8) for z in (-0.01, 0.01)]
    )
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    ms = rdmesh.MeshSurface((corners, faces))
    assert ms.sign_method == "side"
    pts = np.array([[0.0, 0.0, 0.01], [0.3, -0.2, -0.01]])
    gap = ms.sheet_gap(pts)
    assert np.allclose(gap, 0.02, atol=0.002)
    rep = ms.input_report(pts)
    assert rep["close_sheets"]["points"] == 2 and not rep["incomplete"]
    assert "nearly touch" in rep["statement"]
    # Sheets far closer than the probes' step (about 4e-4 here) are measured too.
    thin = corners * np.array([1.0, 1.0, 0.01])
    gap = rdmesh.MeshSurface((thin, faces)).sheet_gap(pts * np.array([1.0, 1.0, 0.01]))
    np.testing.assert_allclose(gap, 0.0002, rtol=1e-3)
    # Away from thin parts the gap is the cap, 2 x CLOSE_SHEETS x R, and nothing is said.
    ball = rdmesh.MeshSurface(sphere_mesh((0, 0, 0), 1.0))
    assert ball.input_report(np.array([[1.0, 0.0, 0.0]])) is None


# -- exact crossings of dual segments with a closed mesh -------------------------------


def test_segment_hits_lie_on_the_faces_they_name():
    v, f = mc_mesh(torus_f, -1.6, 1.6, 32)
    core = MeshDistance(v, f, side=True)
    rng = np.random.default_rng(11)
    a = v[rng.integers(0, len(v), 3000)] + rng.normal(0, 0.1, (3000, 3))
    seg = np.stack([a, a + rng.normal(0, 0.3, (3000, 3))], axis=1)
    hit, t, face = core.segment_hits(seg)
    assert len(hit) > 1000 and np.all(np.diff(hit) >= 0)
    assert np.all((t >= 0) & (t <= 1))
    p = seg[hit, 0] + t[:, None] * (seg[hit, 1] - seg[hit, 0])
    # Each point is on its face's plane and inside the face (barycentric >= 0).
    a0, b0, c0 = (v[f[face, i]] for i in range(3))
    n = np.cross(b0 - a0, c0 - a0)
    area2 = np.einsum("ij,ij->i", n, n)
    bary = np.stack(
        [np.einsum("ij,ij->i", np.cross(y - p, z - p), n) / area2
         for y, z in ((b0, c0), (c0, a0), (a0, b0))], axis=1,
    )  # fmt: skip
    assert np.all(bary > -1e-9) and np.allclose(bary.sum(axis=1), 1.0)
    # And no face is missed: a segment has hits exactly when its ends differ in
    # side or it has an even number >= 2 of them.
    side = core.side(seg.reshape(-1, 3)).reshape(-1, 2)
    count = np.bincount(hit, minlength=len(seg))
    assert np.array_equal(count % 2 == 1, side[:, 0] != side[:, 1])


def test_segment_hits_refuse_bad_segments():
    v, f = sphere_mesh((0, 0, 0), 0.8, 16)
    core = MeshDistance(v, f, side=True)
    with pytest.raises(ValueError, match=r"\(k, 2, 3\)"):
        core.segment_hits(np.zeros((4, 3)))
    with pytest.raises(ValueError, match="not finite"):
        core.segment_hits(np.array([[[0.0, 0, 0], [np.nan, 0, 0]]]))
    hit, t, face = core.segment_hits(np.zeros((1, 2, 3)))  # zero length: one NaN
    assert hit.tolist() == [0] and np.isnan(t).all()


def torus_and_segments(seed: int) -> tuple[rdmesh.MeshSurface, np.ndarray]:
    """A marching-cubes torus and 2000 random segments about its vertices."""
    surface = rdmesh.MeshSurface(mc_mesh(torus_f, -1.6, 1.6, 32))
    rng = np.random.default_rng(seed)
    v = surface.vertices
    a = v[rng.integers(0, len(v), 2000)] + rng.normal(0, 0.1, (2000, 3))
    return surface, np.stack([a, a + rng.normal(0, 0.2, (2000, 3))], axis=1)


def test_exact_crossings_match_the_sampled_search():
    from rdmesh.refine.facets import _sampled_crossings
    from rdmesh.sampling.roots import Crossings

    surface, seg = torus_and_segments(12)
    *found, cos, unsure = surface.exact_crossings(seg)
    cr = Crossings(*found)
    assert not unsure.any() and len(cr.segment) > 500
    d = seg[:, 1] - seg[:, 0]
    length = np.linalg.norm(d, axis=1)
    u = d / length[:, None]
    apex = seg[:, 0]
    ref, _ = _sampled_crossings(surface, seg, apex, 0.05 * np.ones(len(seg)), u)
    # The samples may miss two crossings closer than their spacing; never
    # one that the exact search does not have.
    exact_n, ref_n = cr.count(len(seg)), ref.count(len(seg))
    same = exact_n == ref_n
    assert same.mean() > 0.97 and np.all(ref_n <= exact_n)
    both = np.isin(cr.segment, np.flatnonzero(same))
    assert np.allclose(cr.point[both], ref.point[np.isin(ref.segment, np.flatnonzero(same))],
                       atol=1e-7)  # fmt: skip
    assert np.array_equal(cr.rising[both], ref.rising[np.isin(ref.segment, np.flatnonzero(same))])
    assert np.all((cos > 0) & (cos <= 1 + 1e-12))


def test_degenerate_hits_are_left_to_sampling():
    v, f = sphere_mesh((0, 0, 0), 0.8, 16)
    surface = rdmesh.MeshSurface((v, f))
    w = surface.vertices
    vert = w[0]
    face = surface.faces[0]
    mid = 0.5 * (w[face[0]] + w[face[1]])
    centre = w[face].mean(axis=0)
    seg = np.array([
        [1.5 * vert, 0.5 * vert],  # through a vertex
        [1.5 * mid, 0.5 * mid],  # through an edge
        [1.5 * centre, 0.5 * centre],  # through a face's interior
        # along an edge: in its faces' planes
        [w[face[0]] - (w[face[1]] - w[face[0]]), w[face[1]]],
    ])  # fmt: skip
    segment, _, _, rising, _, unsure = surface.exact_crossings(seg)
    assert unsure.tolist() == [True, True, False, True]
    assert segment.tolist() == [2] and not rising[0]  # going in


def test_remeshing_uses_exact_crossings_and_keeps_the_topology(monkeypatch):
    surface = rdmesh.MeshSurface(mc_mesh(torus_f, -1.6, 1.6, 40))
    exact = rdmesh.mesh_surface(surface, radius_bound=0.05)
    assert surface.segment_queries == exact.stats["segment_queries"] > 0
    assert surface.evaluations == exact.stats["evaluations"] > 0
    monkeypatch.setattr(surface, "exact_crossings", None)
    sampled = rdmesh.mesh_surface(surface, radius_bound=0.05)
    for m in (exact, sampled):
        assert m.is_closed_manifold() and m.complete
        assert m.min_angle >= 30.0 - 1e-6
    assert exact.topology() == sampled.topology()
    # The sampled run also skips the segments that the bound 1 clears.
    assert exact.stats["evaluations"] < 0.6 * sampled.stats["evaluations"]
    # The vertices lie on the input mesh.
    assert np.abs(surface.signed_distance(exact.vertices)).max() < 1e-9 * surface.radius


# -- open meshes: crossings from the faces and the winding number's jumps --------------


def open_sphere(n=32):
    """A sphere mesh of radius 0.8 with a cap above z = 0.7 removed (one hole)."""
    v, f = sphere_mesh((0, 0, 0), 0.8, n)
    return v, f[v[f].mean(axis=1)[:, 2] < 0.7]


def test_hole_balls_cover_each_hole():
    from rdmesh.surfaces._mesh_crossings import HOLE_MARGIN, hole_balls

    v, f = open_sphere()
    centres, radii = hole_balls(v, f)
    assert len(centres) == 1
    rim = np.sqrt(0.8**2 - 0.7**2)  # the hole's radius
    assert np.allclose(centres[0], [0, 0, 0.7], atol=0.05)
    assert abs(radii[0] / HOLE_MARGIN - rim) < 0.05
    closed = sphere_mesh((0, 0, 0), 0.8, 16)
    assert len(hole_balls(*closed)[0]) == 0


def test_running_sums_restart_with_each_segment():
    from rdmesh.surfaces._mesh_crossings import _cumsum_by

    group = np.array([0, 0, 0, 2, 2, 5])
    x = np.array([1.0, -1.0, 1.0, -1.0, -1.0, 1.0])
    assert _cumsum_by(group, x).tolist() == [1.0, 0.0, 1.0, -1.0, -2.0, 1.0]


def test_open_mesh_crossings_match_the_sampled_search():
    from rdmesh.refine.facets import _sampled_crossings
    from rdmesh.sampling.roots import Crossings
    from rdmesh.surfaces._mesh_crossings import _near_balls, hole_balls

    surface = rdmesh.MeshSurface(open_sphere(), holes="fill")
    assert surface.sign_method == "winding" and surface.exact_crossings is not None
    rng = np.random.default_rng(13)
    v = surface.vertices
    a = v[rng.integers(0, len(v), 3000)] + rng.normal(0, 0.1, (3000, 3))
    seg = np.stack([a, a + rng.normal(0, 0.2, (3000, 3))], axis=1)
    *found, cos, unsure = surface.exact_crossings(seg)
    cr = Crossings(*found)
    # Segments in the hole's ball are left to sampling; almost no others are.
    near_hole = _near_balls(seg, *hole_balls(surface.vertices, surface.faces))
    assert near_hole.sum() > 100 and unsure[near_hole].all() and unsure[~near_hole].mean() < 0.02
    d = seg[:, 1] - seg[:, 0]
    length = np.linalg.norm(d, axis=1)
    u = d / length[:, None]
    ref, _ = _sampled_crossings(surface, seg, seg[:, 0], 0.05 * np.ones(len(seg)), u)
    sure = np.flatnonzero(~unsure)
    exact_n, ref_n = cr.count(len(seg))[sure], ref.count(len(seg))[sure]
    assert len(cr.segment) > 500 and (exact_n == ref_n).mean() > 0.97 and np.all(ref_n <= exact_n)
    both = np.isin(cr.segment, sure[exact_n == ref_n])
    other = np.isin(ref.segment, sure[exact_n == ref_n])
    assert np.allclose(cr.point[both], ref.point[other], atol=1e-7)
    assert np.array_equal(cr.rising[both], ref.rising[other])


def test_a_face_against_its_neighbours_leaves_its_segments_to_sampling(monkeypatch):
    v, f = open_sphere()
    f = f.copy()
    low = int(np.argmin(v[f].mean(axis=1)[:, 2]))  # a face at the bottom, far from the hole
    f[low] = f[low, ::-1]
    # MeshSurface turns such a face back; kept turned (as on a Moebius strip,
    # which cannot be oriented), its segments are left to sampling.
    monkeypatch.setattr("rdmesh.surfaces._mesh_input.coherently_oriented", lambda f: f)
    surface = rdmesh.MeshSurface((v, f))
    c = v[f[low]].mean(axis=0)
    side = c * [1, 1, 0] + [0.3, 0.0, -0.3]  # through the bottom, beside that face
    seg = np.array([[c + [0, 0, 0.1], c - [0, 0, 0.1]], [side - [0, 0, 0.6], side]])
    segment, _, _, _, _, unsure = surface.exact_crossings(seg)
    assert unsure.tolist() == [True, False]
    assert segment.tolist() == [1]


def test_remeshing_an_open_mesh_with_exact_crossings_keeps_the_topology(monkeypatch):
    surface = rdmesh.MeshSurface(open_sphere(), holes="fill")
    exact = rdmesh.mesh_surface(surface, radius_bound=0.06)
    assert exact.stats["segment_queries"] > 0
    monkeypatch.setattr(surface, "exact_crossings", None)
    sampled = rdmesh.mesh_surface(surface, radius_bound=0.06)
    for m in (exact, sampled):
        assert m.is_closed_manifold() and m.complete  # the hole is closed
        assert m.min_angle >= 30.0 - 1e-6
    assert exact.topology() == sampled.topology()
    # Fewer, though the hole's ball (a good part of this small sphere) is
    # sampled, and the sampled run clears most segments by the slope bound.
    assert exact.stats["evaluations"] < sampled.stats["evaluations"]


def test_the_gradient_is_a_unit_vector_off_the_holes_band():
    surface = rdmesh.MeshSurface(open_sphere(), holes="fill")
    p = np.array([[0.0, 0.0, 0.7], [0.0, 0.0, -0.9], [0.9, 0.0, 0.0], [0.0, 0.0, 0.0]])
    assert surface.unit_gradient_at(p).tolist() == [False, True, True, True]
    g = surface.grad(p[1:])
    assert np.allclose(np.linalg.norm(g, axis=1), 1.0)
    closed = rdmesh.MeshSurface(sphere_mesh((0, 0, 0), 0.8, 16))
    assert closed.unit_gradient_at(p).all()


# -- the faces of exact crossings ---------------------------------------------------


def test_point_map_keeps_the_smallest_id_per_exact_point():
    from rdmesh.core import PointMap

    rng = np.random.default_rng(3)
    p = rng.normal(size=(5000, 3))
    ids, again = rng.integers(0, 100, 5000), rng.integers(0, 100, 2000)
    pts, all_ids = np.concatenate([p, p[:2000]]), np.concatenate([ids, again])
    m = PointMap()
    for part in np.array_split(rng.permutation(len(pts)), 7):  # any order, grown in steps
        m.add(pts[part], all_ids[part])
    want = ids.copy()
    want[:2000] = np.minimum(ids[:2000], again)
    assert m.size == 5000 and np.array_equal(m.get(p), want)
    # One ulp away is another point; -0.0 is 0.0; a NaN is never held.
    assert (m.get(np.nextafter(p, np.inf)) == -1).all()
    m.add(np.array([[-0.0, 1.0, 2.0], [np.nan, 0.0, 0.0]]), np.array([7, 8]))
    assert m.get(np.array([[0.0, 1.0, 2.0], [np.nan, 0.0, 0.0]])).tolist() == [7, -1]
    with pytest.raises(ValueError, match=">= 0"):
        m.add(p[:1], np.array([-1]))
    with pytest.raises(ValueError, match="one per point"):
        m.add(p[:2], np.array([1]))
    m.clear()
    assert m.size == 0 and (m.get(p) == -1).all()


@settings(max_examples=60, deadline=None)
@given(
    calls=st.lists(
        st.lists(st.tuples(st.integers(0, 40), st.integers(0, 9), st.booleans()), max_size=80),
        max_size=6,
    )
)
def test_point_map_holds_what_a_dict_of_smallest_ids_holds(calls):
    """Any calls of add, in any order and with repeats (of 41 points, some
    with -0.0 for 0.0), hold the smallest id given for each point."""
    from rdmesh.core import PointMap

    base = np.random.default_rng(5).normal(size=(41, 3))
    base[::4, 1] = 0.0
    m, want = PointMap(), {}
    for call in calls:
        if not call:
            continue
        idx, ids, negate = (np.array(x) for x in zip(*call, strict=True))
        pts = base[idx].copy()
        pts[negate & (pts == 0.0).any(axis=1), 1] *= -1.0  # 0.0 -> -0.0 where it is 0
        m.add(pts, ids)
        for i, k in zip(idx.tolist(), ids.tolist(), strict=True):
            want[i] = min(k, want.get(i, k))
    got = m.get(base)
    assert m.size == len(want)
    assert got.tolist() == [want.get(i, -1) for i in range(len(base))]


def test_crossings_give_their_faces_and_the_faces_normals():
    from rdmesh.surfaces._mesh_queries import queried_gradient

    surface, seg = torus_and_segments(14)
    v = surface.vertices
    _, _, point, _, _, _ = surface.exact_crossings(seg)
    face = surface.crossing_faces(point)
    assert len(point) > 500 and (face >= 0).all()
    # Each crossing lies on the face it gives.
    assert np.abs(surface.signed_distance(point)).max() < 1e-12
    f = surface.faces[face]
    n = surface._normals[face]
    assert np.abs(np.einsum("ij,ij->i", point - v[f[:, 0]], n)).max() < 1e-12
    # The gradient there is that face's normal, what the closest-point query
    # gives but where a crossing ties between faces (on an edge).
    g = surface.grad(point)
    assert np.array_equal(g, n)
    same = np.abs(g - queried_gradient(surface, point)).max(axis=1) < 1e-12
    assert same.mean() > 0.99
    # Other points are queried.
    off = point + 1e-3
    assert (surface.crossing_faces(off) == -1).all()
    assert np.array_equal(surface.grad(off), queried_gradient(surface, off))


class _FacesSpy:
    """A MeshSurface's PointMap, counting how many points asked for were held."""

    def __init__(self, inner, watch):
        self.inner, self.asked, self.held = inner, 0, 0
        #: The face held for the point ``watch`` at each add.
        self.watch, self.watched = watch, []

    def add(self, points, ids):
        self.watched.append(int(self.inner.get(self.watch)[0]))
        self.inner.add(points, ids)

    def get(self, points):
        out = self.inner.get(points)
        self.asked, self.held = self.asked + len(out), self.held + int((out >= 0).sum())
        return out

    def clear(self):
        self.inner.clear()

    @property
    def size(self):
        return self.inner.size


def test_a_run_keeps_its_crossings_faces_only_while_it_runs():
    surface = rdmesh.MeshSurface(sphere_mesh((0, 0, 0), 0.8, 16))
    stale = np.array([[0.0, 0.0, 0.8]])  # not a crossing of the run
    spy = surface._on_face = _FacesSpy(surface._on_face, stale)
    spy.add(stale, np.array([0]))
    first = rdmesh.mesh_surface(surface, radius_bound=0.1)
    # Gradients were asked at facet centres and samples, nearly all crossings.
    assert spy.asked > len(first.vertices) and spy.held > 0.9 * spy.asked
    # Forgotten when the run starts (the stale point) and when it ends.
    assert len(spy.watched) > 1 and set(spy.watched) == {-1}
    assert spy.size == 0
    second = rdmesh.mesh_surface(surface, radius_bound=0.1)
    assert np.array_equal(first.vertices, second.vertices)
    assert np.array_equal(first.faces, second.faces)


# -- closed meshes that intersect themselves: w beside the faces ----------------------


@pytest.fixture(scope="module")
def overlapping():
    return rdmesh.MeshSurface(overlapping_spheres())


def test_face_sides_of_overlapping_spheres(overlapping):
    """Faces of one sphere inside the other have w = 1 in front and 2 behind
    (no hit on them is a crossing); the others 0 and 1; the crossing faces are
    left to the winding number."""
    sides = overlapping._face_sides
    v, f = overlapping.vertices, overlapping.faces
    c = v[f].mean(axis=1)
    first = np.arange(len(f)) < len(sphere_mesh((0, 0, 0), 1.0)[1])
    # The other sphere's centre, by each face's sphere; clearly inside or outside it.
    other = np.where(first[:, None], [1.2, 0.0, 0.0], [0.0, 0.0, 0.0])
    depth = np.linalg.norm(c - other, axis=1)
    assert np.all(sides.code[depth < 0.9] == 0) and np.all(sides.w[depth < 0.9] == [1, 2])
    assert np.all(sides.code[depth > 1.1] == 1) and np.all(sides.w[depth > 1.1] == [0, 1])
    assert np.all(sides.code[overlapping.self_intersections.ravel()] == -1)
    assert np.isnan(sides.w[sides.code == -1]).all()
    # A closed mesh that does not intersect itself has the side test instead.
    assert getattr(rdmesh.MeshSurface(sphere_mesh((0, 0, 0), 1.0)), "_face_sides", None) is None


def test_closest_points_and_distance_need_no_winding_number(overlapping, monkeypatch):
    """Unsigned queries (the distance check, the report's sheet gaps) ask only
    for the closest face: no winding number, whose cost is the query's many times."""
    from rdmesh.surfaces import _mesh_queries

    pts = np.random.default_rng(3).uniform(-1.5, 2.7, (500, 3))
    expected = np.abs(overlapping.signed_distance(pts))
    inside = np.abs(overlapping._winding_factor(pts)) == 1.0  # w far from 1/2

    def refuse(*args, **kwargs):
        raise AssertionError("winding number asked for")

    monkeypatch.setattr(_mesh_queries, "winding_numbers", refuse)
    closest, face = overlapping.closest_points(pts)
    d = overlapping.distance(pts)
    assert np.allclose(d, np.linalg.norm(pts - closest, axis=1), rtol=1e-12, atol=1e-15)
    # Where the sign factor is +-1, |signed distance| is the distance.
    assert inside.sum() > 400 and np.allclose(d[inside], expected[inside], rtol=1e-12)
    # The closest point lies on its face's plane.
    v, f = overlapping.vertices, overlapping.faces
    n = overlapping._normals[face]
    assert np.allclose(np.einsum("ij,ij->i", closest - v[f[face, 0]], n), 0.0, atol=1e-12)


def _random_segments(v, n, seed):
    rng = np.random.default_rng(seed)
    a = v[rng.integers(0, len(v), n)] + rng.normal(0, 0.1, (n, 3))
    return np.stack([a, a + rng.normal(0, 0.3, (n, 3))], axis=1)


def test_crossings_beside_the_faces_equal_those_from_the_winding_number(overlapping):
    from rdmesh.surfaces._mesh_crossings import winding_crossings

    seg = _random_segments(overlapping.vertices, 4000, 3)
    fast = winding_crossings(overlapping, seg)
    sides, overlapping._face_sides = overlapping._face_sides, None
    try:
        slow = winding_crossings(overlapping, seg)
    finally:
        overlapping._face_sides = sides
    assert np.array_equal(fast[-1], slow[-1]) and (~fast[-1]).sum() > 3500
    for a, b in zip(fast[:-1], slow[:-1], strict=True):
        assert np.array_equal(a, b)
    assert len(fast[0]) > 1000


def test_winding_beside_the_faces_equals_the_evaluated_one(overlapping):
    from rdmesh.surfaces._mesh_sides import winding_beside

    seg = _random_segments(overlapping.vertices, 5000, 4)
    pts = seg.reshape(-1, 3)
    _, closest, face, _ = overlapping._query(pts)
    w = winding_beside(overlapping._face_sides, pts, closest, face)
    read = ~np.isnan(w)
    assert read.mean() > 0.5
    assert np.array_equal(w[read], np.round(overlapping.winding_number(pts[read])))
    # Inside both spheres (w = 2) is read too.
    assert (w == 2).sum() > 100


def test_remeshing_with_the_faces_sides_gives_the_same_mesh(overlapping, monkeypatch):
    from rdmesh.refine import methods

    # The distance check measures the union's faces only with the sides: off in both runs.
    monkeypatch.setattr(methods, "deviation_stage", lambda *a, **k: None)
    fast = rdmesh.mesh_surface(overlapping, radius_bound=0.2, distance_bound=0.02)
    sides, overlapping._face_sides = overlapping._face_sides, None
    try:
        slow = rdmesh.mesh_surface(overlapping, radius_bound=0.2, distance_bound=0.02)
    finally:
        overlapping._face_sides = sides
    assert np.array_equal(fast.vertices, slow.vertices)
    assert np.array_equal(fast.faces, slow.faces)
    assert fast.stats["evaluations"] < slow.stats["evaluations"]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(*[st.integers(0, 7)] * 3), min_size=1, max_size=40), st.booleans())
def test_closed_oriented_and_merged_points_match_numpys_row_unique(faces, sphere):
    """The sort-key versions give what numpy's row-wise unique gives."""
    import trimesh
    from rdmesh._vectors import unique_rows
    from rdmesh.surfaces._mesh_input import is_closed_oriented

    f = np.asarray(faces, np.int64)
    if sphere:  # a closed, oriented mesh with the drawn faces added
        f = np.concatenate([np.asarray(trimesh.creation.icosphere(subdivisions=1).faces), f])
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    _, counts = np.unique(np.sort(directed, axis=1), axis=0, return_counts=True)
    want = len(np.unique(directed, axis=0)) == len(directed) and bool(np.all(counts == 2))
    assert is_closed_oriented(f) == want
    assert is_closed_oriented(np.asarray(trimesh.creation.icosphere(subdivisions=1).faces))
    points = f.astype(float) / 3.0  # repeated rows
    u, inverse = np.unique(points, axis=0, return_inverse=True)
    got_u, got_inverse = unique_rows(points)
    assert np.array_equal(u, got_u) and np.array_equal(inverse.reshape(-1), got_inverse)


def test_every_component_of_a_closed_mesh_gets_a_seed():
    """A vertex of each component of a closed input that does not intersect
    itself: on the surface, one per component, and the seeding is proven."""
    from rdmesh.sampling.components import find_components

    a, speck = sphere_mesh((0, 0, 0), 1.0, 16), sphere_mesh((3, 0, 0), 0.05, 16)
    v = np.concatenate([a[0], speck[0]])
    f = np.concatenate([a[1], speck[1] + len(a[0])])
    surface = rdmesh.MeshSurface((v, f), feature_angle=None)
    found = find_components(surface, np.random.default_rng(0))
    assert found is not None and found.proven
    assert np.abs(surface.signed_distance(found.points)).max() == 0.0
    # Up to six spread vertices per component (its lowest and highest along
    # each axis), so that a component's seeds alone span facets.
    on_speck = found.points[:, 0] > 1.5
    for part in (found.points[on_speck], found.points[~on_speck]):
        assert 4 <= len(part) <= 6
        assert np.ptp(part, axis=0).min() > 0
    # With seeds on the large sphere already, only the speck needs one.
    on_large = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    on_large = surface.closest_points(on_large)[0]
    rest = find_components(surface, np.random.default_rng(0), seeds=on_large)
    assert rest.proven and np.array_equal(rest.points, found.points[on_speck])
    mesh = rdmesh.mesh_surface(surface, radius_bound=0.3, distance_bound=0.03)
    assert mesh.report["seeding"]["level"] == "proven" and mesh.report["components"] == 2
    # Open or self-intersecting inputs: no proof.
    assert (
        find_components(rdmesh.MeshSurface(overlapping_spheres()), np.random.default_rng(0))
        is None
    )


BOX_V = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
BOX_F = np.array(
    [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
     [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]
)  # fmt: skip


@pytest.mark.parametrize("exponent", [66, 460, -66])
def test_mesh_queries_scale_exactly_with_huge_and_tiny_coordinates(exponent):
    # CGAL's ray casting retried forever at a box of 1e20 (its random directions
    # vanish next to the coordinates), and its exact fallback raised SIGFPE at
    # 1e140 (NaN from overflow); the queries now run in an exactly scaled frame.
    code = f"""
import numpy as np
from rdmesh.core import MeshDistance
BOX_V, BOX_F = np.array({BOX_V.tolist()}), np.array({BOX_F.tolist()})
s = 2.0 ** {exponent}
plain, big = MeshDistance(BOX_V, BOX_F, side=True), MeshDistance(BOX_V * s, BOX_F, side=True)
p = np.random.default_rng(0).uniform(-1, 1, (200, 3))
d0, c0, f0, s0 = plain.query(p)
d1, c1, f1, s1 = big.query(p * s)
assert np.array_equal(d1, d0 * s) and np.array_equal(c1, c0 * s)
assert np.array_equal(f1, f0) and np.array_equal(s1, s0)
seg = np.stack([p[:100], p[100:]], axis=1)
for a, b in zip(plain.segment_hits(seg), big.segment_hits(seg * s)):
    assert np.array_equal(a, b, equal_nan=True)
assert np.array_equal(plain.winding_number(p), big.winding_number(p * s))
if s < 1:  # a point far from a tiny mesh overflows when scaled up: refused, not cast
    try:
        big.side(np.array([[1e300, 0.0, 0.0]]))
    except ValueError as exc:
        assert "scaled to the mesh's size" in str(exc)
    else:
        raise AssertionError("no error")
print("ok")
"""
    res = run_python(code, timeout=120)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.split() == ["ok"]


def test_a_huge_box_is_meshed_closed():
    code = f"""
import numpy as np, rdmesh, trimesh
BOX_V, BOX_F = np.array({BOX_V.tolist()}), np.array({BOX_F.tolist()})
m = rdmesh.mesh_surface(rdmesh.MeshSurface((BOX_V * 1e20, BOX_F)), radius_bound=0.2e20)
t = trimesh.Trimesh(m.vertices, m.faces, process=False)
assert t.is_watertight and t.euler_number == 2 and m.complete
assert np.abs(np.abs(m.vertices).max() - 0.5e20) < 1e6
print("ok")
"""
    res = run_python(code, timeout=120)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.split() == ["ok"]


@pytest.mark.parametrize(
    "scale, offset, words",
    [(1e60, 0.0, "bounding radius"), (1e-13, 0.0, "bounding radius"), (1.0, 1e12, "translate")],
)
def test_coordinates_too_large_small_or_far_are_refused(scale, offset, words):
    # A box 1e12 radii from the origin kept 4 digits of its size (its topology
    # tests failed); at 1e60 the mesh lost half its vertices; at 1e-16 no surface
    # was found.
    with pytest.raises(rdmesh.MeshInputError, match=words):
        rdmesh.MeshSurface((BOX_V * scale + offset, BOX_F))
    with pytest.raises(ValueError, match=words):
        rdmesh.ImplicitSurface(
            lambda p: np.linalg.norm(p - offset, axis=1) - scale, ((offset,) * 3, 2 * scale)
        )
