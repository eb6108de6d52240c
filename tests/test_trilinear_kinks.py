"""The trilinear interpolant's sharp kinks, protected as feature curves (issue 30)."""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
from rdmesh.features.check import repair_sites
from rdmesh.features.graph import FeatureCurve, build_graph
from rdmesh.features.protect import protect
from rdmesh.refine.feature_curves import kink_balls, without_kinks_near
from rdmesh.surfaces import trilinear_kinks as tk

#: The lens's ridge: the data fall by SLOPE per voxel on both sides of x = C.
C, N, BOWL = 12.0, 25, 0.01


def lens(slope: float, bowl: float = BOWL, **kw) -> rdmesh.VolumeSurface:
    """A lens-shaped solid whose rim lies on the grid plane x = 12: the
    data fall by ``slope`` per voxel away from the plane, so the trilinear
    isosurface has a kink along a near-circle of radius sqrt(0.5 / BOWL)."""
    i = np.arange(N, dtype=float)
    x, y, z = np.meshgrid(i, i, i, indexing="ij")
    v = 1.0 - slope * np.abs(x - C) - bowl * ((y - C) ** 2 + (z - C) ** 2)
    return rdmesh.VolumeSurface(v, isovalue=0.5, interpolation="linear", **kw)


def rim_angle(slope: float) -> float:
    """Degrees between the one-sided normals at the lens's rim."""
    r = np.sqrt(0.5 / BOWL)
    return float(np.degrees(2.0 * np.arctan2(slope, 2.0 * BOWL * r)))


def one_sided_angle(surface, points: np.ndarray, axis: int) -> np.ndarray:
    e = np.zeros(3)
    e[axis] = 1e-7
    a, b = surface.grad(points - e), surface.grad(points + e)
    a /= np.linalg.norm(a, axis=1)[:, None]
    b /= np.linalg.norm(b, axis=1)[:, None]
    return np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1, 1)))


def test_a_sharp_rim_is_one_closed_curve_on_the_isosurface_and_the_plane():
    s = lens(1.0)
    assert rim_angle(1.0) > tk.KINK_ANGLE
    curves = tk.kink_curves(s)
    assert len(curves) == 1 and curves[0].closed and curves[0].source == tk.KINK_SOURCE
    p = curves[0].points
    assert np.all(p[:, 0] == C)
    assert np.abs(s.values(p) - s.isovalue).max() < 1e-12
    # The bilinear pieces follow the circle of the quadratic closely.
    r = np.sqrt(0.5 / BOWL)
    assert curves[0].length == pytest.approx(2 * np.pi * r, rel=0.01)
    assert one_sided_angle(s, p, 0).min() >= tk.KINK_LOW - 1e-6


def test_a_mild_rim_is_not_protected():
    assert rim_angle(0.3) < tk.KINK_ANGLE
    assert tk.kink_curves(lens(0.3)) == []


def test_the_projection_lands_on_the_curve_in_its_plane():
    s = lens(1.0)
    (c,) = tk.kink_curves(s)
    rng = np.random.default_rng(0)
    x = c.points + rng.normal(scale=0.05, size=c.points.shape)
    y = c.project(x)
    assert np.all(y[:, 0] == C)
    assert np.abs(s.values(y) - s.isovalue).max() < 1e-10
    assert np.linalg.norm(y - c.points, axis=1).max() < 0.5


def test_an_ambiguous_face_pairs_its_crossings_by_the_saddle():
    # Corners a = e = 1, b = c = 0: the saddle value is 0.5.
    one, zero = np.ones(1), np.zeros(1)
    for iso, cut in ((0.4, ({0, 1}, {2, 3})), (0.6, ({3, 0}, {1, 2}))):
        ends, owner = tk._branch_ends(one, zero, zero, one, iso)
        assert len(ends) == 2 and np.all(owner == 0)
        # Which edges each branch joins: 0 w=0, 1 u=1, 2 w=1, 3 u=0.
        got = []
        for branch in ends:
            edges = set()
            for u, w in branch:
                edges |= {k for k, on in enumerate((w == 0, u == 1, w == 1, u == 0)) if on}
            got.append(edges)
        # iso below the saddle: the inside corners a, e join through the
        # centre, so the branches cut off b (edges 0, 1) and c (2, 3).
        assert sorted(map(sorted, got)) == sorted(map(sorted, cut))


def test_curves_meeting_at_a_narrow_angle_lose_the_shorter():
    o = np.zeros(3)
    long_ = np.array([o, [2.0, 0, 0]])
    t = np.radians(10)
    short = np.array([o, [np.cos(t), np.sin(t), 0]])
    wide = np.array([o, [0, 1.0, 0]])
    curves = [FeatureCurve(p, False, tk.KINK_SOURCE) for p in (long_, short)]
    kept = tk._without_narrow_meetings(curves, 10.0, 1.0)
    assert len(kept) == 1 and kept[0].length == pytest.approx(2.0)
    curves = [FeatureCurve(p, False, tk.KINK_SOURCE) for p in (long_, wide)]
    assert len(tk._without_narrow_meetings(curves, 10.0, 1.0)) == 2


def test_kinks_near_a_place_are_dropped_and_other_curves_kept():
    kink = FeatureCurve(np.array([[0, 0, 0], [1.0, 0, 0]]), False, tk.KINK_SOURCE)
    far = FeatureCurve(np.array([[0, 5, 0], [1.0, 5, 0]]), False, tk.KINK_SOURCE)
    box = FeatureCurve(np.array([[0, 0, 1.0], [1.0, 0, 1]]), False, "box edge")
    g = build_graph([kink, far, box], 10.0, np.array([[3.0, 3, 3]]))
    fewer = without_kinks_near(g, np.array([0.5, 0.1, 0]), 10.0, 1.0)
    assert [c.source for c in fewer.curves] == [tk.KINK_SOURCE, "box edge"]
    assert fewer.curves[0].points[0, 1] == 5.0
    # The isolated corner stays; the dropped curve's corners go.
    assert len(fewer.corners) == 5
    assert any(np.allclose(x, [3, 3, 3]) for x in fewer.corners)
    # Only the box edge near the place: not a kink's failure.
    assert without_kinks_near(g, np.array([0.5, 0, 1.5]), 10.0, 0.2) is None
    assert without_kinks_near(g, None, 10.0, 1.0) is None


def test_a_protection_failure_says_where():
    g = build_graph(
        [
            FeatureCurve(np.array([[0, 0, 0], [1.0, 0, 0]])),
            FeatureCurve(np.array([[0, 1e-8, 0.0], [1, 1e-8, 0]])),
        ],
        2.0,
    )
    with pytest.raises(rdmesh.FeatureError) as exc:
        protect(g, lambda x: np.full(len(x), 0.1), 2.0)
    assert exc.value.where is not None and exc.value.where.shape == (3,)
    assert abs(exc.value.where[1]) < 1e-6


@pytest.fixture(scope="module")
def sharp_lens_mesh():
    return rdmesh.mesh_surface(lens(1.0), radius_bound=1.0)


def test_a_sharp_lens_is_closed_with_its_rim_kept(sharp_lens_mesh):
    m = sharp_lens_mesh
    assert m.report["closed_manifold"] and m.report["euler"] == [2]
    assert len(m.unresolved) == 0
    assert m.features is not None and m.features.held
    assert set(m.features.sources) == {tk.KINK_SOURCE}
    # The rim is a chain of mesh edges on the plane x = 12.
    rim = m.vertices[np.concatenate(m.features.curves)]
    assert np.all(rim[:, 0] == C)
    # Away from the balls the angle bound holds.
    heavy = (m.weights[m.faces] > 0).any(axis=1)
    assert m.angles[~heavy].min() >= 30.0 - 1e-6


def test_kink_balls_are_not_shrunk_by_repairs(sharp_lens_mesh):
    m = sharp_lens_mesh
    assert m.features.repairs == 0
    centres = m.vertices[m.weights > 0]
    soft = (centres, np.ones(len(centres), bool))
    # Low angles next to kink balls are sites without soft, none with.
    assert len(repair_sites(m, 30.0)[0]) > 0
    assert len(repair_sites(m, 30.0, soft)[0]) == 0


def test_kink_balls_mark_kink_curves_and_their_corners_only():
    kink = FeatureCurve(np.array([[0, 0, 0], [1.0, 0, 0]]), False, tk.KINK_SOURCE)
    box = FeatureCurve(np.array([[1.0, 0, 0], [1.0, 1, 0]]), False, "box edge")
    g = build_graph([kink, box], 10.0)
    balls = protect(g, lambda x: np.full(len(x), 0.2), 10.0)

    class Plan:
        features, balls_ = g, balls

    Plan.balls = balls
    centres, soft = kink_balls(Plan)
    on_kink = (balls.curve == 0) | ((balls.corner >= 0) & (centres[:, 0] == 0.0))
    assert np.array_equal(soft, on_kink)


@pytest.mark.slow
def test_without_protection_the_sharp_lens_leaves_points_unresolved():
    # A smaller lens (rim radius 3.5), its rim's normals 148 degrees apart: the
    # thin wedge at the rim looks the same at every scale, so refinement stops
    # at the floor there (closed since the pinched vertices are relabelled).
    m = rdmesh.mesh_surface(lens(1.0, 0.04, features="none"), radius_bound=1.0)
    assert not m.complete and len(m.unresolved) > 0


def test_kinks_that_cannot_be_protected_are_dropped_and_the_rest_kept():
    from types import SimpleNamespace

    from rdmesh.refine.criteria import FacetCriteria
    from rdmesh.refine.methods import _protect

    s = lens(1.0)
    (rim,) = tk.kink_curves(s)
    # Two parallel kink curves 1e-5 apart: no balls above the floor fit.
    a = FeatureCurve(np.array([[2.0, 2, 2], [3, 2, 2]]), False, tk.KINK_SOURCE)
    b = FeatureCurve(np.array([[2.0, 2, 2 + 1e-5], [3, 2, 2 + 1e-5]]), False, tk.KINK_SOURCE)
    g = build_graph([rim, a, b], s.radius)
    scan = SimpleNamespace(crossings=np.zeros((0, 3)))
    graph, balls = _protect(s, FacetCriteria(30.0, 1.0, None), g, scan, None, [])
    assert len(graph.curves) == 1 and graph.curves[0].closed
    assert balls is not None and np.all(balls.centres[:, 0] == pytest.approx(C))
    # With only the failing pair, nothing is left to protect.
    graph, balls = _protect(
        s, FacetCriteria(30.0, 1.0, None), build_graph([a, b], s.radius), scan, None, []
    )
    assert graph.empty and balls is None
    # A failure on a curve that is not a kink is not ours to drop.
    a.source = b.source = "given"
    with pytest.raises(rdmesh.FeatureError):
        _protect(s, FacetCriteria(30.0, 1.0, None), build_graph([a, b], s.radius), scan, None, [])


def test_kink_curves_closer_than_the_gap_lose_the_shorter():
    long_ = FeatureCurve(np.array([[0.0, 0, 0], [2, 0, 0]]), False, tk.KINK_SOURCE)
    for offset, kept in ((0.5 * tk.GAP, 1), (10 * tk.GAP, 2)):
        short = FeatureCurve(np.array([[0.5, offset, 0], [1.5, offset, 0]]), False, tk.KINK_SOURCE)
        out = tk._apart([long_, short], tk.GAP)
        assert len(out) == kept and out[0] is long_
    # Meeting at a common end point is not closeness (the narrow-meeting rule's).
    other = FeatureCurve(np.array([[2.0, 0, 0], [2, 1, 0]]), False, tk.KINK_SOURCE)
    assert len(tk._apart([long_, other], tk.GAP)) == 2
