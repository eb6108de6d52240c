"""rdmesh.sampling.screen: dual-segment samples thinned by a slope bound (issue 30)."""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
from rdmesh import core
from rdmesh.refine import mesher
from rdmesh.refine.facets import DualSamples, _sampled_crossings
from rdmesh.sampling.screen import (
    SAFETY,
    SlopeBound,
    SlopeField,
    end_slopes,
    node_slopes,
    ruled_out,
    slope_bound,
)
from rdmesh.surfaces import SURFACES

#: f = |x| - 1: 1-Lipschitz, so 1 is a proven bound.
SPHERE = rdmesh.ImplicitSurface(lambda p: np.linalg.norm(p, axis=1) - 1.0, ((0, 0, 0), 2.0))


def _segments(rng, k):
    """Chords near the unit sphere: many with both ends outside and two
    crossings, some grazing, some crossing once, some missing."""
    q = rng.normal(size=(k, 3))
    q *= (rng.uniform(0.7, 1.3, k) / np.linalg.norm(q, axis=1))[:, None]
    d = rng.normal(size=(k, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    length = rng.uniform(0.01, 2.5, k)
    a = q - (rng.uniform(0, 1, k) * length)[:, None] * d
    seg = np.stack([a, a + length[:, None] * d], axis=1)
    # Apexes and radii as the core's facets have them: the samples are dense
    # near the apex, sparse far from it.
    apex = q + rng.normal(scale=0.05, size=(k, 3))
    rho = rng.uniform(0.01, 0.3, k)
    return seg, apex, rho, d


def _ends(surface, seg):
    return surface(np.concatenate([seg[:, 0], seg[:, 1]])).reshape(2, len(seg)).T


def test_proven_bound_loses_no_crossing_and_skips_samples():
    rng = np.random.default_rng(3)
    seg, apex, rho, u = _segments(rng, 4000)
    e0 = SPHERE.evaluations
    full, _ = _sampled_crossings(SPHERE, seg, apex, rho, u)
    e1 = SPHERE.evaluations
    thin, seen = _sampled_crossings(SPHERE, seg, apex, rho, u, slope=1.0)
    full_evals, thin_evals = e1 - e0, SPHERE.evaluations - e1
    n_full = np.bincount(full.segment, minlength=len(seg))
    n_thin = np.bincount(thin.segment, minlength=len(seg))
    assert (n_full >= 2).sum() > 100  # hidden pairs are there to be lost
    np.testing.assert_array_equal(n_thin, n_full)
    # The same brackets, so the same roots.
    np.testing.assert_array_equal(thin.s, full.s)
    assert thin_evals < full_evals
    # The slopes seen are lower bounds on the true one (1).
    assert 0.5 < seen.max() <= 1.0 + 1e-9


def test_ruled_out_is_the_slope_rule():
    ends = np.array([[1.0, 2.0], [1.0, 2.0], [-1.0, -2.0], [1.0, -2.0], [0.0, 0.5]])
    length = np.array([2.0, 4.0, 2.0, 0.1, 0.1])
    # |f(a)| + |f(b)| > L |b - a| with one sign; a sign change never (0 is outside).
    assert ruled_out(ends, length, 1.0).tolist() == [True, False, True, False, True]
    assert ruled_out(ends, length, np.array([2.0, 0.1, 1.0, 1.0, 10.0])).tolist() == [
        False, True, True, False, False,
    ]  # fmt: skip
    steep = end_slopes(ends, np.array([2.0, 4.0, 2.0, 0.1, 1e-12]), 1.0)
    np.testing.assert_allclose(steep, [0.5, 0.25, 0.5, 30.0, 0.0])


def test_select_keeps_the_rows_samples():
    rng = np.random.default_rng(4)
    seg, apex, rho, _ = _segments(rng, 50)
    smp = DualSamples.of(seg, apex, rho)
    rows = np.array([0, 3, 4, 20, 49])
    sub = smp.select(rows)
    one = DualSamples.of(seg[rows], apex[rows], rho[rows])
    np.testing.assert_array_equal(sub.offsets, one.offsets)
    np.testing.assert_array_equal(sub.s, one.s)
    np.testing.assert_array_equal(sub.interior, one.interior)


def test_a_bound_below_the_true_slope_rules_pairs_out():
    """The rule is applied: a bound 100 times too small loses hidden pairs."""
    rng = np.random.default_rng(5)
    seg, apex, rho, u = _segments(rng, 2000)
    full, _ = _sampled_crossings(SPHERE, seg, apex, rho, u)
    wrong, _ = _sampled_crossings(SPHERE, seg, apex, rho, u, slope=0.01)
    assert len(wrong.segment) < len(full.segment)


def _field(f, n=24, spacing=0.25):
    """A SlopeField of ``f`` on an axis-aligned grid centred at the origin."""
    offset = np.full(3, 0.5 * spacing * (n - 1))
    ax = np.arange(n) * spacing - offset[0]
    pts = np.stack(np.meshgrid(ax, ax, ax, indexing="ij"), -1).reshape(-1, 3)
    values = f(pts).reshape(n, n, n)
    within = (np.linalg.norm(pts, axis=1) <= 2.5).reshape(n, n, n)
    return SlopeField(values, spacing, np.zeros(3), np.eye(3), offset, within)


def test_slope_bound_sources():
    mesh = rdmesh.MeshSurface(_cube_mesh())
    b = slope_bound(mesh, None)
    assert b == SlopeBound(1.0, True)
    seg = np.zeros((1, 2, 3))
    b.observe(seg, np.array([50.0]), np.array([1.0]))
    assert b.value == 1.0  # a proven bound is never raised
    torus = SURFACES["torus"].make()
    assert slope_bound(torus, None) is None
    field = _field(lambda p: p[:, 0] ** 2)
    est = slope_bound(torus, field)
    assert not est.proven and est.value == pytest.approx(SAFETY * field.in_ball)


def test_field_is_local_and_raised_where_a_slope_exceeds_it():
    # f = x^2: the slope grows with |x|, so short segments near x = 0 get a
    # smaller bound than the ball's, long ones the ball's.
    field = _field(lambda p: p[:, 0] ** 2)
    b = SlopeBound(SAFETY * field.in_ball, False, field)
    near = np.array([[[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]]])
    far = np.array([[[2.0, 0.0, 0.0], [2.1, 0.0, 0.0]]])
    long = np.array([[[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]])
    at = b.for_segments(np.concatenate([near, far, long]))
    assert at[0] < at[1] <= at[2] == b.value
    # Slope near 0 is at most 2 * 0.75 (grid edges within two spacings).
    assert at[0] <= SAFETY * 2 * 0.75 + 1e-12
    # A steeper slope seen near 0 raises the field there, and the ball's bound.
    b.observe(near, np.array([100.0]), at[:1])
    assert b.for_segments(near)[0] == SAFETY * 100.0
    assert b.value == SAFETY * 100.0
    # Off the grid the field gives no local bound.
    assert np.isinf(field.at(np.array([[50.0, 0.0, 0.0]])))[0]


def test_node_slopes_of_a_linear_function():
    h = 0.1
    x, y, z = np.meshgrid(*[np.arange(8) * h] * 3, indexing="ij")
    # The gradient's length, whatever its direction against the grid's axes.
    values = 3.0 * x - 2.0 * y + 0.5 * z
    np.testing.assert_allclose(node_slopes(values, h), np.sqrt(9 + 4 + 0.25))
    values[2, 3, 4] = np.nan
    assert np.isinf(node_slopes(values, h)[2, 3, 4])


def test_grid_clears_segments_only_where_the_bound_forbids_a_zero():
    # f = x on a unit grid: a segment whose middle's node has |f| = 5 and
    # lies within 1 of it is cleared with |grad f| <= 1 (5 > 1 x 1), not
    # with a bound of 10, nor near x = 0.
    ax = np.arange(11.0) - 5.0
    x = np.meshgrid(ax, ax, ax, indexing="ij")[0]
    g = core.GridField(x, np.zeros(3), np.eye(3), np.full(3, 5.0), 1.0)
    seg = np.array([
        [[4.6, 0.0, 0.0], [5.0, 0.5, 0.0]],
        [[4.6, 0.0, 0.0], [5.0, 0.5, 0.0]],
        [[-0.2, 0.0, 0.0], [0.2, 0.0, 0.0]],
        [[40.0, 0.0, 0.0], [41.0, 0.0, 0.0]],
    ])  # fmt: skip
    v = g.clearing_values(seg, np.array([1.0, 10.0, 1.0, 1.0]))
    assert v[0] == 5.0 and np.isnan(v[1:]).all()
    with pytest.raises(ValueError, match="one entry per segment"):
        g.clearing_values(seg, np.ones(3))
    rdt = core.RestrictedDelaunay(np.zeros(3), 1.0)
    with pytest.raises(ValueError, match="scale > 0"):
        rdt.set_clearing(g, g, 0.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="cap must be"):
        rdt.set_clearing_cap(-1.0)


def test_grid_field_rejects_bad_input():
    with pytest.raises(ValueError, match="3-D"):
        core.GridField(np.zeros((4, 4)), np.zeros(3), np.eye(3), np.zeros(3), 1.0)
    with pytest.raises(ValueError, match="positive"):
        core.GridField(np.zeros((2, 2, 2)), np.zeros(3), np.eye(3), np.zeros(3), 0.0)
    with pytest.raises(ValueError, match="non-finite"):
        core.GridField(np.zeros((2, 2, 2)), [np.nan, 0, 0], np.eye(3), np.zeros(3), 1.0)
    g = core.GridField(np.arange(8.0).reshape(2, 2, 2), np.zeros(3), np.eye(3), np.zeros(3), 1.0)
    assert g.at(np.array([[1.0, 0.0, 1.0], [0.4, 0.4, 0.4], [2.0, 0, 0]])).tolist() == [
        5.0, 0.0, np.inf,
    ]  # fmt: skip
    with pytest.raises(ValueError, match="shape"):
        g.segment_bounds(np.zeros((3, 3)), 1.0, 2.0, 10.0)
    with pytest.raises(ValueError, match="one entry per point"):
        g.raise_to(np.zeros((2, 3)), np.ones(3), 1)


def test_mesh_unchanged_with_fewer_evaluations(monkeypatch):
    """On the torus the thinned samples give the same mesh as all of them."""
    surface = SURFACES["torus"].make()
    on = rdmesh.mesh_surface(surface, radius_bound=0.08, distance_bound=0.008, workers=2)
    assert on.stats["slope_bound"]["proven"] is False
    assert on.stats["slope_bound"]["value"] > 0
    monkeypatch.setattr(mesher, "slope_bound", lambda *a: None)
    off = rdmesh.mesh_surface(
        SURFACES["torus"].make(), radius_bound=0.08, distance_bound=0.008, workers=1
    )
    assert off.stats["slope_bound"] is None
    # The grid cleared facets in the core (never handed out) only with the bound.
    assert on.stats["facets_cleared"] > 0 == off.stats["facets_cleared"]
    np.testing.assert_array_equal(on.vertices, off.vertices)
    np.testing.assert_array_equal(on.faces, off.faces)
    assert on.stats["evaluations"] < off.stats["evaluations"]


def _cube_mesh():
    v = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    f = np.array(
        [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
         [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]
    )  # fmt: skip
    return v, f


def test_cos_by_slope_lower_bounds_the_cosine():
    from rdmesh.refine.facets import _cos_by_slope

    rng = np.random.default_rng(7)
    n = rng.normal(size=(200, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    u = rng.normal(size=(200, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    u[:20] = np.cross(n[:20], u[:20])  # tangent to the sphere there
    u[:20] /= np.linalg.norm(u[:20], axis=1)[:, None]
    bound = np.full(200, 2.0)  # |grad f| = 1 <= 2
    cos = _cos_by_slope(SPHERE, n, u, bound, np.full(200, np.nan))
    true = np.abs(np.einsum("ij,ij->i", n, u))
    shown = ~np.isnan(cos)
    assert np.isnan(cos[:20]).all() and shown.sum() > 150
    np.testing.assert_allclose(cos[shown], true[shown] / 2.0, atol=1e-6)
    # Known derivatives (the root search's last brackets) cost no evaluation.
    before = SPHERE.evaluations
    known = np.einsum("ij,ij->i", n, u)
    known[::2] = np.nan
    again = _cos_by_slope(SPHERE, n, u, bound, known)
    assert SPHERE.evaluations - before == 2 * 100
    np.testing.assert_allclose(again[shown], cos[shown], atol=1e-6)
    assert np.array_equal(np.isnan(again), ~shown)
    # A known slope above the bound is rounding, not a slope: differences decide.
    before = SPHERE.evaluations
    steep = np.full(200, 1e3)
    np.testing.assert_array_equal(_cos_by_slope(SPHERE, n, u, bound, steep), cos)
    assert SPHERE.evaluations - before == 2 * 200


def test_f_alone_mesh_unchanged_with_fewer_gradients(monkeypatch):
    """Crossings shown transversal by the derivative along the segment skip the
    central-difference gradient: the same mesh, fewer evaluations."""
    from rdmesh.refine import facets

    base = SURFACES["torus"].make()

    def run():
        s = rdmesh.ImplicitSurface(base.f, base.bounding_sphere)
        return rdmesh.mesh_surface(s, radius_bound=0.08, distance_bound=0.008)

    on = run()
    monkeypatch.setattr(facets, "_cos_by_slope", lambda s, p, u, b, k: np.full(len(p), np.nan))
    off = run()
    np.testing.assert_array_equal(on.vertices, off.vertices)
    np.testing.assert_array_equal(on.faces, off.faces)
    assert on.stats["evaluations"] < off.stats["evaluations"]


def _ball_mesh():
    import trimesh

    return rdmesh.MeshSurface(trimesh.creation.icosphere(subdivisions=3), feature_angle=None)


def test_proven_grid_clears_only_segments_that_miss_a_closed_mesh():
    """A closed mesh's grid keeps a proven lower bound of |f| (the signed
    distance, 1-Lipschitz) at every node, also where it skipped the node:
    a segment it clears meets no face (CGAL's exact test), and it clears many."""
    from rdmesh.sampling.grid import grid_scan

    surface = _ball_mesh()
    scan = grid_scan(surface, np.random.default_rng(0), 48)
    field = scan.slopes
    assert field is not None and field.in_ball == 1.0
    rng = np.random.default_rng(1)
    k = 20000
    start = rng.uniform(-1.3, 1.3, (k, 3))
    seg = np.stack([start, start + rng.normal(scale=0.03, size=(k, 3))], axis=1)
    cleared = ~np.isnan(field.values.clearing_values(seg, np.ones(k)))
    hit = np.zeros(k, bool)
    hit[surface._core.segment_hits(seg)[0]] = True
    assert hit.sum() > 200 and cleared.sum() > 0.3 * k
    assert not (cleared & hit).any()


def test_closed_mesh_facets_cleared_in_the_core_give_the_same_mesh(monkeypatch):
    surface = _ball_mesh()
    on = rdmesh.mesh_surface(surface, radius_bound=0.1, distance_bound=0.01)
    assert on.stats["slope_bound"] == {"value": 1.0, "proven": True}
    monkeypatch.setattr(mesher, "clear_in_core", lambda *a, **k: None)
    off = rdmesh.mesh_surface(_ball_mesh(), radius_bound=0.1, distance_bound=0.01)
    assert on.stats["facets_cleared"] > 0 == off.stats["facets_cleared"]
    np.testing.assert_array_equal(on.vertices, off.vertices)
    np.testing.assert_array_equal(on.faces, off.faces)
    assert on.stats["segment_queries"] < off.stats["segment_queries"]


def test_closed_mesh_grid_crossings_are_exact_and_cost_no_root_search(monkeypatch):
    """A closed mesh's seeding crossings come from its exact segment queries:
    on the faces, on the same grid edges as the root search's, with fewer
    evaluations of f."""
    from rdmesh.sampling.grid import grid_scan

    exact = _ball_mesh()
    scan = grid_scan(exact, np.random.default_rng(0), 32)
    searched = _ball_mesh()
    monkeypatch.setattr(searched, "exact_crossings", None)
    ref = grid_scan(searched, np.random.default_rng(0), 32)
    assert exact.evaluations < searched.evaluations
    assert exact.segment_queries > 0
    d, *_ = exact._core.query(scan.crossings)
    assert len(scan.crossings) == len(ref.crossings) > 100
    assert d.max() < 1e-12
    # The same crossings, to the root search's tolerance.
    gap = np.linalg.norm(scan.crossings - ref.crossings, axis=1)
    assert gap.max() < 1e-6


def test_closed_mesh_sphere_is_clear():
    """``sphere_clear`` (no search for f <= 0 on the bounding sphere) only for
    closed meshes, where f > 0 on and outside the sphere."""
    surface = _ball_mesh()
    assert surface.sphere_clear
    rng = np.random.default_rng(2)
    u = rng.normal(size=(5000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    r = surface.radius * rng.uniform(1.0, 3.0, size=(5000, 1))
    assert (surface(surface.centre + r * u) > 0).all()
    v, f = surface.vertices, surface.faces
    assert not rdmesh.MeshSurface((v, f[1:]), holes="fill").sphere_clear
    # Its hole kept, the open mesh is capped while meshing: closed, so clear.
    capped = rdmesh.MeshSurface((v, f[1:]))
    assert capped.sphere_clear and (capped(capped.centre + r * u) > 0).all()
