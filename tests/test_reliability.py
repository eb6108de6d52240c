"""Reliability: no silent loss, no runaway refinement, no crash from threads or Ctrl-C.

Each test here failed (or crashed, or did not end) before the fix it guards.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import rdmesh
from rdmesh._regions import regions
from rdmesh.refine import mesher as mesher_module
from rdmesh.refine.stages import Candidates
from rdmesh.sampling import roots
from rdmesh.sampling.roots import SegmentSamples, line_crossings
from rdmesh.surfaces import SURFACES
from rdmesh.topology.snapshot import Snapshot


def _sphere_f(p):
    return np.einsum("ij,ij->i", p, p) - 1.0


# -- root finding ---------------------------------------------------------------------------


def test_pair_of_crossings_in_the_first_interval_is_found():
    """A chord at height 0.99 through the unit sphere from x = -0.2, 3 intervals:
    both crossings lie in the first interval, which the dip search skipped."""
    s = SURFACES["sphere"].make()
    o = np.array([[-0.2, 0.99, 0.0]])
    d = np.array([[1.0, 0.0, 0.0]])
    samples = SegmentSamples.uniform(np.array([1.2]), 3)
    cr = line_crossings(s, o, d, samples, 1e-13)
    x = np.sqrt(1 - 0.99**2)
    assert np.allclose(cr.point[:, 0], [-x, x], atol=1e-10)
    assert cr.rising.tolist() == [False, True]
    # Mirrored: the pair in the last interval.
    cr = line_crossings(s, -o, -d, samples, 1e-13)
    assert np.allclose(np.sort(cr.point[:, 0]), [-x, x], atol=1e-10)


def test_failed_bracket_is_flagged_not_used(monkeypatch):
    """A bracket whose root search does not converge gives no surface point,
    and its segment is reported."""
    real = roots.elementwise.find_root

    def failing(*args, **kwargs):
        res = real(*args, **kwargs)
        res.status[0] = -2  # maxiter on the first bracket
        return res

    monkeypatch.setattr(roots.elementwise, "find_root", failing)
    s = SURFACES["sphere"].make()
    o = np.array([[-2.0, 0.0, 0.0], [-2.0, 0.5, 0.0]])
    d = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    cr = line_crossings(s, o, d, SegmentSamples.uniform(np.full(2, 4.0), 8), 1e-12)
    assert cr.failed.tolist() == [0]
    assert len(cr.point) == 3  # the other crossing of segment 0 and both of segment 1
    assert np.allclose(np.linalg.norm(cr.point, axis=1), 1.0, atol=1e-9)


# -- runaway refinement on bad but plausible functions ----------------------------------------


@pytest.mark.parametrize("scale", [1e-200, 1e200])
def test_scaled_f_meshes_like_f(scale):
    """Gradient norms by squaring underflowed (overflowed), so every crossing
    looked tangential and refinement never ended."""
    plain = rdmesh.mesh_surface(
        rdmesh.ImplicitSurface(_sphere_f, ((0, 0, 0), 2.0)), radius_bound=0.2
    )
    scaled = rdmesh.mesh_surface(
        rdmesh.ImplicitSurface(lambda p: scale * _sphere_f(p), ((0, 0, 0), 2.0)),
        radius_bound=0.2,
        max_vertices=20 * len(plain.vertices),
    )
    assert scaled.complete and scaled.is_closed_manifold()
    assert abs(len(scaled.vertices) - len(plain.vertices)) <= 0.05 * len(plain.vertices)


def test_zero_gradient_is_an_oracle_error():
    surface = rdmesh.ImplicitSurface(
        _sphere_f, ((0, 0, 0), 2.0), gradient=lambda p: np.zeros((len(p), 3))
    )
    with pytest.raises(rdmesh.OracleError, match="gradient is zero or not finite"):
        rdmesh.mesh_surface(surface, radius_bound=0.2, max_vertices=100_000)


def test_quantised_f_ends():
    """An integer-valued f: central differences vanish off the steps."""
    surface = rdmesh.ImplicitSurface(
        lambda p: np.round(10 * (np.sqrt(np.einsum("ij,ij->i", p, p)) - 1)),
        ((0, 0, 0), 2.0),
    )
    try:
        m = rdmesh.mesh_surface(surface, radius_bound=0.2, max_vertices=200_000)
    except rdmesh.OracleError as exc:
        assert "gradient" in str(exc)
    else:
        assert len(m.vertices) < 200_000


# -- violations without a point, stalls, the round cap ----------------------------------------


class _Stage:
    """A stage that proposes fixed points, with some failures lacking a point."""

    def __init__(self, name, centres, radii, stuck):
        self.name, self.centres, self.radii, self.stuck = name, centres, radii, stuck

    def candidates(self, snap):
        return Candidates(self.name, self.centres, self.radii, True, 1, self.stuck)


def _with_extra_stage(monkeypatch, stage):
    """Append ``stage`` to the Boissonnat-Oudot method's last phase."""
    real = mesher_module.METHODS["boissonnat-oudot"]

    def plan(*args, **kwargs):
        p = real(*args, **kwargs)
        p.phases[-1].append(stage)
        return p

    monkeypatch.setitem(mesher_module.METHODS, "boissonnat-oudot", plan)


def test_violation_without_point_is_unresolved(monkeypatch):
    where = np.array([[0.0, 0.0, 1.0]])
    _with_extra_stage(monkeypatch, _Stage("probe", np.zeros((0, 3)), np.zeros(0), where))
    m = rdmesh.mesh_surface(SURFACES["sphere"].make(), radius_bound=0.3)
    assert not m.complete
    assert np.array_equal(m.unresolved, where)
    assert "unresolved" in m.stats["stop_reason"]
    assert not m.topology_certified


def test_batch_without_new_vertex_stops(monkeypatch):
    """A batch of existing samples used to repeat until the round cap."""
    first = rdmesh.mesh_surface(SURFACES["sphere"].make(), radius_bound=0.3)
    v = first.vertices[:1]
    _with_extra_stage(monkeypatch, _Stage("stuck", v, np.ones(1), np.zeros((0, 3))))
    with pytest.raises(rdmesh.RefinementStalled, match="no progress") as info:
        rdmesh.mesh_surface(SURFACES["sphere"].make(), radius_bound=0.3)
    assert info.value.mesh is not None and not info.value.mesh.complete
    assert info.value.mesh.stats["rounds"] < 10


def test_round_cap_leaves_points_unresolved(monkeypatch):
    monkeypatch.setattr(mesher_module, "MAX_ROUNDS", 1)
    m = rdmesh.mesh_surface(SURFACES["torus"].make(), radius_bound=0.05)
    assert not m.complete and len(m.unresolved) > 0


# -- the debug check ------------------------------------------------------------------------------


def test_debug_check_catches_a_wrong_surface_centre(monkeypatch):
    monkeypatch.setenv("RDMESH_CHECK", "1")
    real = Snapshot.facets

    def shifted(self, mask=0):
        tri, centres, flags = real(self, mask)
        return tri, centres * 0.5, flags  # centres off the surface: balls not empty

    monkeypatch.setattr(Snapshot, "facets", shifted)
    with pytest.raises(rdmesh.InternalCheckError, match="not empty"):
        rdmesh.mesh_surface(SURFACES["sphere"].make(), radius_bound=0.3)


def test_debug_check_is_on_in_the_test_suite():
    assert os.environ.get("RDMESH_CHECK") == "1"


# -- regions scale and join what is near ---------------------------------------------------------


def test_regions_join_points_within_the_link():
    rng = np.random.default_rng(0)
    a = rng.normal(0, 0.01, (500, 3))
    b = rng.normal(0, 0.01, (300, 3)) + [1.0, 0, 0]
    line = np.column_stack([np.linspace(3, 4, 200), np.zeros(200), np.zeros(200)])
    rs = regions(np.concatenate([a, b, line]), 0.05)
    assert [r["points"] for r in rs] == [500, 300, 200]
    assert np.allclose(rs[1]["centre"], [1, 0, 0], atol=0.01)


def test_regions_of_a_million_points():
    pts = np.random.default_rng(1).uniform(-1, 1, (1_000_000, 3))
    rs = regions(pts, 0.05)
    assert sum(r["points"] for r in rs) == 1_000_000
    assert len(rs) == 1  # a dense cloud is one region


# -- threads and Ctrl-C ---------------------------------------------------------------------------


def _batch_case(name):
    m = rdmesh.mesh_surface(SURFACES[name].make(), radius_bound=0.15, seed=3)
    return m.vertices, m.faces


def test_meshes_from_a_thread_pool_equal_one_at_a_time():
    names = ["sphere", "torus", "tanglecube", "blob_line"] * 2
    alone = [_batch_case(n) for n in names[:4]]
    with ThreadPoolExecutor(4) as pool:
        together = list(pool.map(_batch_case, names))
    for (v, f), (v2, f2) in zip(alone * 2, together, strict=True):
        assert np.array_equal(v, v2) and np.array_equal(f, f2)


# -- the bounding sphere, and Ctrl-C in the report ---------------------------------------------


def test_surface_poking_out_of_the_sphere_is_found():
    """A thin spike reaches 1e-4 beyond the bounding sphere: the grid's points on
    the sphere miss it; the search from the outermost samples finds it."""

    def f(p):
        r = np.sqrt(np.einsum("ij,ij->i", p, p))
        spike = 0.1001 * np.exp(-(p[:, 0] ** 2 + p[:, 1] ** 2) / 0.02**2) * (p[:, 2] > 0)
        return r - 0.9 - spike

    surface = rdmesh.ImplicitSurface(f, ((0, 0, 0), 1.0))
    with pytest.raises(rdmesh.BoundingSphereError, match="on the bounding sphere"):
        rdmesh.mesh_surface(surface, radius_bound=0.05)


def test_ctrl_c_in_the_report_gives_the_mesh(monkeypatch):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(mesher_module, "topology_report", interrupted)
    with pytest.raises(rdmesh.Interrupted) as info:
        rdmesh.mesh_surface(SURFACES["sphere"].make(), radius_bound=0.3)
    m = info.value.mesh
    assert m.is_closed_manifold() and not m.complete and m.report == {}


def test_ctrl_c_during_refinement_is_not_a_budget_stop():
    rounds = []

    def progress(info):
        rounds.append(info["round"])
        if len(rounds) == 2:
            raise KeyboardInterrupt

    with pytest.raises(rdmesh.Interrupted) as info:
        try:
            rdmesh.mesh_surface(SURFACES["torus"].make(), radius_bound=0.1, progress=progress)
        except rdmesh.BudgetExceeded:  # going on with a budget's partial mesh
            pytest.fail("Ctrl-C was caught as a budget stop")
    assert info.value.reason == "interrupted"
    m = info.value.mesh
    assert not m.complete and len(m.faces) > 0 and m.stats["rounds"] == 2


@pytest.fixture
def python_sigint():
    """Python's own SIGINT handler for the test, whatever an earlier test or
    library left installed; the previous one is put back after."""
    import signal

    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, before)


def _ctrl_c_to_this_thread() -> None:
    """SIGINT to the main thread: sent to the process, another thread (Dask's,
    from earlier tests) may take it, and it reaches Python after the block."""
    import signal
    import threading

    signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)
    for _ in range(1000):  # the handler runs between bytecodes
        pass


def test_ctrl_c_while_the_core_settles_is_held_to_the_end(python_sigint):
    """A Ctrl-C during the wait for the core's worker must not land inside
    concurrent.futures (it could leave a future's lock taken: a hang); it is
    raised once the wait is over."""
    import signal

    from rdmesh.refine.pipeline import _ctrl_c_deferred

    reached = []
    with pytest.raises(KeyboardInterrupt), _ctrl_c_deferred():
        _ctrl_c_to_this_thread()
        reached.append(True)
    assert reached
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_ctrl_c_while_settling_after_ctrl_c_is_not_raised_twice(python_sigint):
    from rdmesh.refine.pipeline import _ctrl_c_deferred

    with pytest.raises(KeyboardInterrupt) as info:
        try:
            raise KeyboardInterrupt("first")
        except KeyboardInterrupt:
            with _ctrl_c_deferred():
                _ctrl_c_to_this_thread()
            raise
    assert str(info.value) == "first"


def test_taking_candidates_keeps_what_is_not_per_point():
    from dataclasses import fields

    c = Candidates(
        "stage", np.arange(9.0).reshape(3, 3), np.ones(3), np.array([True, False, True]), 7,
        stuck=np.full((2, 3), 5.0), soft=np.array([False, True, False]),
    )  # fmt: skip
    keep = np.array([True, False, True])
    t = c.take(keep)
    per_point = {"centres", "radii", "topological", "soft"}
    for f in fields(Candidates):
        want = getattr(c, f.name)
        want = want[keep] if f.name in per_point else want
        assert np.array_equal(getattr(t, f.name), want), f.name
    # A scalar topological flag is spread over the points kept.
    assert Candidates("s", c.centres, c.radii, True).take(keep).topological.tolist() == [True] * 2
