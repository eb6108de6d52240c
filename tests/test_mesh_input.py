"""MeshSurface on real-data problems (issue 30): the pseudo-normal sign,
self-intersecting input, and the time limit's message."""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
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
    # Away from thin parts the gap is the cap, 2 x CLOSE_SHEETS x R, and nothing is said.
    ball = rdmesh.MeshSurface(sphere_mesh((0, 0, 0), 1.0))
    assert ball.input_report(np.array([[1.0, 0.0, 0.0]])) is None


# -- dual segments proven empty by the signed distance's Lipschitz constant ------------


def test_segments_proven_empty_do_not_meet_the_surface():
    from rdmesh.refine.facets import no_crossing_proven

    v, f = sphere_mesh((0.1, 0, 0), 0.8)
    surface = rdmesh.MeshSurface((v, f))
    assert surface.lipschitz == 1.0
    rng = np.random.default_rng(3)
    a = rng.uniform(-1.2, 1.2, (4000, 3))
    b = a + rng.normal(0, 0.05, (4000, 3))  # f is clamped to 0.1 R
    ends = np.stack([surface(a), surface(b)], axis=1)
    proven = no_crossing_proven(surface, ends, np.linalg.norm(b - a, axis=1))
    assert 0.2 < proven.mean() < 0.99  # a real share, not all
    t = np.linspace(0, 1, 400)
    along = surface((a[proven, None] + t[:, None] * (b - a)[proven, None]).reshape(-1, 3))
    along = along.reshape(-1, len(t))
    # No sign change, and no zero, on any proven segment.
    assert np.all(np.abs(along) > 0) and np.all(along * along[:, :1] > 0)


def test_winding_sign_proves_nothing():
    from rdmesh.refine.facets import no_crossing_proven

    class NoConstant:
        lipschitz = None
        radius = 1.0

    ends = np.array([[1.0, 1.0], [-2.0, -3.0]])
    assert not no_crossing_proven(NoConstant(), ends, np.array([0.1, 0.1])).any()


def test_pruning_empty_segments_keeps_the_mesh_and_saves_evaluations(monkeypatch):
    import rdmesh.refine.facets as facets

    surface = rdmesh.MeshSurface(mc_mesh(torus_f, -1.6, 1.6, 40))
    pruned = rdmesh.mesh_surface(surface, radius_bound=0.08)
    monkeypatch.setattr(
        facets, "no_crossing_proven", lambda surface, ends, length: np.zeros(len(ends), bool)
    )
    full = rdmesh.mesh_surface(surface, radius_bound=0.08)
    assert np.array_equal(pruned.vertices, full.vertices)
    assert np.array_equal(pruned.faces, full.faces)
    assert pruned.stats["evaluations"] < 0.9 * full.stats["evaluations"]


def test_selecting_dual_samples_keeps_each_segments_own():
    from rdmesh.refine.facets import DualSamples

    counts = np.array([2, 5, 3, 4])
    offsets = np.r_[0, np.cumsum(counts)]
    s = np.arange(offsets[-1], dtype=float)
    interior = np.arange(3 * (offsets[-1] - 2 * len(counts)), dtype=float).reshape(-1, 3)
    whole = DualSamples(offsets, s, interior)
    keep = np.array([False, True, False, True])
    got = whole.select(keep)
    parts = [whole.take(slice(i, i + 1)) for i in np.flatnonzero(keep)]
    assert np.array_equal(got.s, np.concatenate([p.s for p in parts]))
    assert np.array_equal(got.interior, np.concatenate([p.interior for p in parts]))
    assert np.array_equal(np.diff(got.offsets), counts[keep])


# -- a run's cap: f clamped a few radius bounds from the surface -----------------------


def test_a_runs_surface_is_clamped_closer_with_the_same_sign_and_zero_set():
    from rdmesh.surfaces._mesh_queries import RUN_CAP, run_surface

    surface = rdmesh.MeshSurface(sphere_mesh((0, 0, 0), 0.8))
    run = run_surface(surface, 0.01)
    assert run is not surface and run.cap == RUN_CAP * 0.01 < surface.cap
    rng = np.random.default_rng(5)
    p = rng.uniform(-1.1, 1.1, (5000, 3))
    full, clamped = surface(p), run(p)
    inside = np.abs(full) < run.cap
    assert inside.any() and (~inside).any()
    assert np.array_equal(clamped[inside], full[inside])
    assert np.array_equal(np.sign(clamped), np.sign(full))
    assert np.all(np.abs(clamped[~inside]) == run.cap)
    assert surface.cap > run.cap  # the user's surface is left as it was
    # A coarse run keeps the surface's own cap.
    assert run_surface(surface, surface.cap) is surface


def test_an_open_mesh_keeps_its_cap():
    from rdmesh.surfaces._mesh_queries import run_surface

    v, f = sphere_mesh((0, 0, 0), 0.8)
    keep = v[f].mean(axis=1)[:, 2] < 0.5  # a bowl: its sign is the winding number's
    surface = rdmesh.MeshSurface((v, f[keep]))
    assert surface.sign_method == "winding"
    assert run_surface(surface, 0.01) is surface


def test_a_runs_evaluations_are_counted_on_the_users_surface():
    surface = rdmesh.MeshSurface(mc_mesh(torus_f, -1.6, 1.6, 40))
    m = rdmesh.mesh_surface(surface, radius_bound=0.03)
    assert m.stats["evaluations"] > 0
    assert surface.evaluations == m.stats["evaluations"]


def test_the_run_cap_keeps_the_topology(monkeypatch):
    from rdmesh.surfaces import _mesh_queries

    surface = rdmesh.MeshSurface(mc_mesh(torus_f, -1.6, 1.6, 40))
    capped = rdmesh.mesh_surface(surface, radius_bound=0.03)
    monkeypatch.setattr(_mesh_queries, "RUN_CAP", 1e9)  # the surface's own cap
    uncapped = rdmesh.mesh_surface(surface, radius_bound=0.03)
    for m in (capped, uncapped):
        assert m.is_closed_manifold() and m.complete
    assert capped.topology() == uncapped.topology()
    assert capped.min_angle >= 30.0 - 1e-6
