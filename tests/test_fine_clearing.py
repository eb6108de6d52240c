"""rdmesh.sampling.fine_clearing: a finer clearing level where the grid clears too little."""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
from rdmesh import core
from rdmesh.sampling import fine_clearing
from rdmesh.sampling.fine_clearing import SUBDIVISIONS, FineClearing
from rdmesh.sampling.screen import SAFETY, SlopeBound, SlopeField
from rdmesh.surfaces import SURFACES

H, N = 0.25, 24
OFFSET = np.full(3, 0.5 * H * (N - 1))


def _nodes():
    ax = np.arange(N) * H - OFFSET[0]
    return np.stack(np.meshgrid(ax, ax, ax, indexing="ij"), -1).reshape(-1, 3)


def _sphere_sdf(p):
    return np.linalg.norm(p, axis=1) - 1.0


def _has_zero(seg):
    """Whether |p| - 1 vanishes on each segment (exact for the unit sphere)."""
    a, b = seg[:, 0], seg[:, 1]
    d = b - a
    t = np.clip(
        -np.einsum("ij,ij->i", a, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-300), 0, 1
    )
    near = np.linalg.norm(a + t[:, None] * d, axis=1)
    far = np.maximum(np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1))
    return (near <= 1.0) & (far >= 1.0)


def _short_segments(rng, k, scale):
    mid = rng.uniform(-1.3, 1.3, (k, 3))
    d = rng.normal(size=(k, 3))
    d *= (rng.uniform(0, scale, k) / np.linalg.norm(d, axis=1))[:, None]
    return np.stack([mid - 0.5 * d, mid + 0.5 * d], axis=1)


def _proven_core(threshold):
    """A core clearing by the unit sphere's signed distance (1-Lipschitz) on the grid."""
    values = _sphere_sdf(_nodes()).reshape(N, N, N)
    field = SlopeField.proven(values, H, np.zeros(3), np.eye(3), OFFSET, 1.0)
    rdt = core.RestrictedDelaunay(np.zeros(3), 2.0)
    rdt.set_clearing(field.values, field.grid, 1.0, 2 * H, 1.0)
    rdt.set_fine_clearing(SUBDIVISIONS, threshold, 0.5 * H)
    return rdt, field


def _hot_core(seed, k):
    """A core that has seen ``k`` short segments, each node hot at its first miss."""
    rdt, _ = _proven_core(threshold=1)
    seg = _short_segments(np.random.default_rng(seed), k, 0.5 * H)
    rdt.grid_clears(seg)
    return rdt, seg, rdt.take_hot_nodes()


def test_filled_cubes_clear_more_and_only_segments_without_a_zero():
    rng = np.random.default_rng(5)
    rdt, _ = _proven_core(threshold=3)
    seg = _short_segments(rng, 20000, 0.5 * H)
    before = rdt.grid_clears(seg)
    hot = rdt.take_hot_nodes()
    assert len(hot) and len(np.unique(hot)) == len(hot)
    assert len(rdt.take_hot_nodes()) == 0  # each node reported once
    points = rdt.fine_points(hot)
    assert points.shape == (len(hot) * SUBDIVISIONS**3, 3)
    # Each subcube centre lies in its node's cube (within half a spacing per axis).
    node_pos = _nodes()[hot]
    off = points.reshape(len(hot), -1, 3) - node_pos[:, None]
    assert np.abs(off).max() <= 0.5 * H * (1 - 1 / SUBDIVISIONS) + 1e-12
    rdt.fill_fine(hot, _sphere_sdf(points), np.ones(len(hot)))
    after = rdt.grid_clears(seg)
    assert (after >= before).all() and after.sum() > before.sum()
    cubes, cleared = rdt.fine_clearing_stats
    assert cubes == len(hot) and cleared == (after & ~before).sum()
    # The bound is proven: nothing cleared meets the sphere, and a fresh set of
    # segments agrees.
    assert not (after & _has_zero(seg)).any()
    more = _short_segments(rng, 20000, 0.5 * H)
    assert not (rdt.grid_clears(more) & _has_zero(more)).any()


def test_a_bound_below_the_slope_clears_segments_that_cross():
    # The check above can fail: with a bound of 0.01 the cubes clear crossing segments.
    rdt, seg, hot = _hot_core(6, 20000)
    rdt.fill_fine(hot, _sphere_sdf(rdt.fine_points(hot)), np.full(len(hot), 0.01))
    assert (rdt.grid_clears(seg) & _has_zero(seg)).any()


def test_long_segments_and_nan_values_are_not_cleared_by_the_cubes():
    rdt, seg, hot = _hot_core(7, 5000)
    points = rdt.fine_points(hot)
    rdt.fill_fine(hot, np.full(len(points), np.nan), np.ones(len(hot)))
    before = rdt.fine_clearing_stats[1]
    rdt.grid_clears(seg)
    assert rdt.fine_clearing_stats[1] == before == 0
    rdt.fill_fine(hot, _sphere_sdf(points), np.ones(len(hot)))  # filled again
    long = seg.copy()
    mid = seg.mean(axis=1)
    long[:, 0] = mid - np.array([0.3 * H, 0, 0])
    long[:, 1] = mid + np.array([0.3 * H, 0, 0])  # 0.6 H > reach 0.5 H
    rdt.grid_clears(long)
    assert rdt.fine_clearing_stats[1] == 0
    rdt.grid_clears(seg)
    assert rdt.fine_clearing_stats[1] > 0


def test_fine_clearing_rejects_bad_input():
    rdt = core.RestrictedDelaunay(np.zeros(3), 2.0)
    with pytest.raises(RuntimeError, match="set_clearing first"):
        rdt.set_fine_clearing(4, 10, 0.1)
    with pytest.raises(RuntimeError, match="no fine clearing"):
        rdt.fine_points(np.zeros(1, np.int64))
    assert len(rdt.take_hot_nodes()) == 0
    assert not rdt.grid_clears(np.zeros((2, 2, 3))).any()  # no clearing set
    rdt, _ = _proven_core(threshold=1)
    with pytest.raises(ValueError, match="subdivisions"):
        rdt.set_fine_clearing(0, 10, 0.1)
    with pytest.raises(ValueError, match="threshold"):
        rdt.set_fine_clearing(4, 0, 0.1)
    with pytest.raises(ValueError, match="reach"):
        rdt.set_fine_clearing(4, 10, np.inf)
    rdt.set_fine_clearing(4, 10, 0.1)
    with pytest.raises(ValueError, match="off the grid"):
        rdt.fine_points(np.array([N**3]))
    with pytest.raises(ValueError, match="off the grid"):
        rdt.fill_fine(np.array([-1]), np.zeros(64), np.ones(1))
    with pytest.raises(ValueError, match="m\\^3 entries"):
        rdt.fill_fine(np.array([5]), np.zeros(63), np.ones(1))
    with pytest.raises(ValueError, match="shape"):
        rdt.grid_clears(np.zeros((3, 3)))


def test_estimated_bounds_take_the_steepest_slope_seen():
    # f = 3x: every slope seen is 3, so each cube's bound is SAFETY x 3; a
    # proven bound is used as it is.
    values = 3.0 * _nodes()[:, 0].reshape(N, N, N)
    field = SlopeField(values, H, np.zeros(3), np.eye(3), OFFSET, np.ones((N, N, N), bool))
    rdt = core.RestrictedDelaunay(np.zeros(3), 2.0)
    rdt.set_clearing(field.values, field.grid, SAFETY, 2 * H, 100.0)

    def f(p):
        return 3.0 * p[:, 0]

    fine = FineClearing(rdt, f, SlopeBound(SAFETY * 3.0, False, field))
    nodes = np.array([100, 2000])
    points = rdt.fine_points(nodes)
    bounds = fine._bounds(nodes, f(points))
    np.testing.assert_allclose(bounds, SAFETY * 3.0)
    proven = FineClearing(rdt, f, SlopeBound(7.0, True, field))
    np.testing.assert_array_equal(proven._bounds(nodes, f(points)), 7.0)
    assert fine_clearing.fine_clearing(rdt, f, None) is None
    assert fine_clearing.fine_clearing(rdt, f, SlopeBound(1.0, True, None)) is None


def test_thin_torus_mesh_unchanged_with_fewer_evaluations(monkeypatch):
    """About the thin torus's core the cubes clear segments the grid cannot,
    and the mesh is the same as without them (and with two workers)."""
    on = rdmesh.mesh_surface(
        SURFACES["thin_torus"].make(), radius_bound=0.02, distance_bound=0.002, workers=2
    )
    monkeypatch.setattr(fine_clearing, "HOT_MISSES", 2**31)
    off = rdmesh.mesh_surface(
        SURFACES["thin_torus"].make(), radius_bound=0.02, distance_bound=0.002
    )
    assert on.stats["fine_clearing"]["cubes"] > 0 and on.stats["fine_clearing"]["cleared"] > 0
    assert off.stats["fine_clearing"] == {"cubes": 0, "cleared": 0}
    np.testing.assert_array_equal(on.vertices, off.vertices)
    np.testing.assert_array_equal(on.faces, off.faces)
    assert on.stats["evaluations"] < off.stats["evaluations"]


def test_a_local_proven_bound_is_used_for_the_cube():
    # A surface with gradient_bound (a volume) bounds each cube itself: the
    # bound it gives for the node's box, whatever the slopes seen; a cube
    # whose bound is over WORTH x the grid's estimate is not filled at all.
    values = 3.0 * _nodes()[:, 0].reshape(N, N, N)
    field = SlopeField(values, H, np.zeros(3), np.eye(3), OFFSET, np.ones((N, N, N), bool))
    rdt = core.RestrictedDelaunay(np.zeros(3), 2.0)
    rdt.set_clearing(field.values, field.grid, SAFETY, 2 * H, 100.0)
    asked = []
    estimate = SAFETY * field.node_slopes.ravel()

    class Local:
        evaluated = 0

        def __call__(self, p):
            Local.evaluated += len(p)
            return 3.0 * p[:, 0]

        def gradient_bound(self, centres, radius):
            asked.append((centres, radius))
            # Within the worth at the first node, above it at the second.
            return np.array([1.0, 1.01 * fine_clearing.WORTH]) * estimate[nodes]

    fine = FineClearing(rdt, Local(), SlopeBound(SAFETY * 3.0, False, field))
    nodes = np.array([100, 2000])
    points = rdt.fine_points(nodes)
    assert fine._local_bounds(nodes, points) is not None
    [(centres, radius)] = asked
    # The centres are the nodes' (their subcubes' centres' mean), the box covers the cube.
    np.testing.assert_allclose(centres, points.reshape(2, -1, 3).mean(axis=1))
    reach = fine_clearing.FINE_REACH
    assert radius == fine_clearing.CUBE_REACH * H >= (np.sqrt(3) / 2 + reach / 2) * H
    # Filling: only the first node's cube, with its own bound.
    fill = []
    rdt_fill = rdt.fill_fine
    fine.rdt = type("Core", (), {
        "take_hot_nodes": lambda self: nodes,
        "fine_points": lambda self, n: rdt.fine_points(n),
        "fill_fine": lambda self, n, v, b: fill.append((n, v, b)) or rdt_fill(n, v, b),
    })()  # fmt: skip
    assert fine.refine() == 1
    [(filled, v, b)] = fill
    assert filled.tolist() == [100] and Local.evaluated == SUBDIVISIONS**3
    np.testing.assert_allclose(b, estimate[[100]])
