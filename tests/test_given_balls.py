"""Surfaces meshed with protecting balls placed beforehand (features=ProtectingBalls).

The balls replace the surface's own curves: nothing is traced or protected,
the mesh keeps every pair of consecutive centres as an edge, and two meshes
given the same balls share those vertices and edges exactly.
"""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
from rdmesh.features import Balls, FeatureGraph, ProtectingBalls
from rdmesh.features.graph import FeatureError
from rdmesh.refine import methods
from rdmesh.refine.criteria import FacetCriteria
from rdmesh.refine.mesher import Mesher

GYROID = "sin(x)*cos(y) + sin(y)*cos(z) + sin(z)*cos(x)"
BOX = [(-2.0, -2.0, -2.0), (2.0, 2.0, 2.0)]


@pytest.fixture(scope="module")
def placed():
    """A clipped gyroid meshed as usual, and the balls that run placed."""
    surface = rdmesh.ImplicitSurface.from_expression(GYROID, ((0, 0, 0), 5.0), clip_box=BOX)
    mesher = Mesher(surface, FacetCriteria(30.0, 0.3, None), topology="manifold-with-boundary")
    mesh = mesher.run()
    assert mesh.features.held and mesh.features.repairs == 0
    return mesh, ProtectingBalls(mesher.plan.balls, mesher.plan.features)


def gyroid(features) -> rdmesh.ImplicitSurface:
    return rdmesh.ImplicitSurface.from_expression(
        GYROID, ((0, 0, 0), 5.0), clip_box=BOX, features=features
    )


def boundary_edges(mesh) -> set[tuple[int, int]]:
    f = mesh.faces
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    keys, counts = np.unique(e, axis=0, return_counts=True)
    return {tuple(k) for k in keys[counts == 1].tolist()}


def test_given_balls_reproduce_the_run_that_placed_them(placed, monkeypatch):
    mesh, given = placed

    def refuse(*args, **kwargs):
        raise AssertionError("nothing may be traced or protected with balls given")

    monkeypatch.setattr(methods, "boundary_curve", refuse)
    monkeypatch.setattr(methods, "protect", refuse)
    again = rdmesh.mesh_surface(gyroid(given), radius_bound=0.3)
    assert np.array_equal(again.vertices, mesh.vertices)
    assert np.array_equal(again.faces, mesh.faces)
    assert again.features.held and again.complete


def test_boundary_edges_are_exactly_the_pairs_of_consecutive_centres(placed):
    _, given = placed
    mesh = rdmesh.mesh_surface(gyroid(given), radius_bound=0.3)
    index = {tuple(p): i for i, p in enumerate(mesh.vertices.tolist())}
    at = np.array([index.get(tuple(c), -1) for c in given.balls.centres.tolist()])
    assert (at >= 0).all()  # every centre is a vertex, bit for bit
    pairs = {tuple(sorted(p)) for p in at[given.balls.pairs].tolist()}
    assert boundary_edges(mesh) == pairs


def test_two_boxes_given_the_balls_of_their_common_face_meet_exactly():
    """A sphere cut by the plane x = 0.1: each half meshed in its own box with
    the balls of the circle on that plane; the halves weld into a closed mesh."""
    centre_x = 0.1
    theta = np.linspace(0.0, 2.0 * np.pi, 400, endpoint=False)
    r = np.sqrt(1.0 - centre_x**2)
    circle = np.c_[np.full(400, centre_x), r * np.cos(theta), r * np.sin(theta)]
    whole = rdmesh.ImplicitSurface.from_expression(
        "x**2 + y**2 + z**2 - 1", ((0, 0, 0), 2.0), features=[np.r_[circle, circle[:1]]]
    )
    mesher = Mesher(whole, FacetCriteria(30.0, 0.15, None), topology="manifold")
    mesher.run()
    balls = mesher.plan.balls
    # Centres on the circle itself, not on its polyline's chords.
    yz = balls.centres[:, 1:]
    balls.centres[:, 1:] = r * yz / np.linalg.norm(yz, axis=1)[:, None]
    balls.boundary[:] = True  # each half has one triangle per edge
    given = ProtectingBalls(balls, mesher.plan.features)
    halves = []
    boxes = [((-1.5, -1.5, -1.5), (centre_x, 1.5, 1.5)), ((centre_x, -1.5, -1.5), (1.5, 1.5, 1.5))]
    for lo, hi in boxes:
        s = rdmesh.ImplicitSurface.from_expression(
            "x**2 + y**2 + z**2 - 1", ((0, 0, 0), 3.0), clip_box=[lo, hi], features=given
        )
        halves.append(rdmesh.mesh_surface(s, radius_bound=0.15))
    for h in halves:
        assert h.features.held and h.complete
    v = np.concatenate([h.vertices for h in halves])
    f = np.concatenate([halves[0].faces, halves[1].faces + len(halves[0].vertices)])
    welded, inverse = np.unique(v, axis=0, return_inverse=True)
    shared = len(v) - len(welded)
    assert shared == len(balls)  # only the ball centres are in both halves
    mesh = rdmesh.SurfaceMesh(welded, inverse.reshape(-1)[f], np.zeros((len(f), 3)))
    assert mesh.is_closed_manifold()
    assert mesh.topology()["euler"] == [2]


def test_a_failed_check_with_given_balls_is_reported_not_repaired(placed):
    _, given = placed
    # The balls of one clip box, meshed in a box one face shorter: the balls on
    # that face are outside it and cannot be edges.
    smaller = [(-2.0, -2.0, -2.0), (2.0, 2.0, 1.5)]
    kept = given.balls.centres[:, 2] <= 1.5
    assert not kept.all()
    s = rdmesh.ImplicitSurface.from_expression(
        GYROID, ((0, 0, 0), 5.0), clip_box=smaller, features=given
    )
    mesh = rdmesh.mesh_surface(s, radius_bound=0.3)
    assert not mesh.features.held and mesh.features.repairs == 0
    assert not mesh.complete and "feature check failed" in mesh.stats["stop_reason"]
    assert len(mesh.features.failed)


def test_empty_balls_trace_nothing(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("nothing may be traced")

    monkeypatch.setattr(methods, "boundary_curve", refuse)
    i0 = np.zeros(0, np.int64)
    none = Balls(np.zeros((0, 3)), np.zeros(0), i0, i0, np.zeros((0, 2), np.int64), i0, index=i0)
    s = rdmesh.ImplicitSurface.from_expression(
        "x**2 + y**2 + z**2 - 1", ((0, 0, 0), 3.0), clip_box=[(-1.5,) * 3, (1.5,) * 3],
        features=ProtectingBalls(none, FeatureGraph()),
    )  # fmt: skip
    mesh = rdmesh.mesh_surface(s, radius_bound=0.2)
    assert mesh.is_closed_manifold() and mesh.features is None


def _balls(**change) -> Balls:
    base = dict(
        centres=np.array([[0.0, 0.0, 1.0], [0.5, 0.0, np.sqrt(0.75)]]),
        radii=np.array([0.2, 0.2]),
        curve=np.array([0, 0]),
        corner=np.array([-1, -1]),
        pairs=np.array([[0, 1]]),
        pair_curve=np.array([0]),
        boundary=np.array([False]),
        index=np.array([0, 1]),
    )
    base.update(change)
    return Balls(**base)


def _graph() -> FeatureGraph:
    from rdmesh.features import FeatureCurve

    return FeatureGraph([FeatureCurve(np.array([[0.0, 0, 1], [0.5, 0, np.sqrt(0.75)]]))])


@pytest.mark.parametrize(
    "change, match",
    [
        ({"radii": np.array([0.2, -0.1])}, "positive"),
        ({"centres": np.array([[0.0, 0.0, np.nan], [0.5, 0.0, 0.8]])}, "finite"),
        ({"pairs": np.array([[0, 2]])}, "pairs must index"),
        ({"pair_curve": np.array([3])}, "pair_curve"),
        ({"boundary": np.array([True, False])}, "one flag per curve"),
        ({"corner": np.array([0, -1])}, "one corner ball per corner"),
        ({"radii": np.array([0.6, 0.2])}, "inside ball"),
        ({"curve": np.array([0])}, "one entry per ball"),
    ],
)
def test_bad_balls_are_refused(change, match):
    with pytest.raises(FeatureError, match=match):
        ProtectingBalls(_balls(**change), _graph())


def test_balls_off_the_surface_are_refused():
    given = ProtectingBalls(_balls(centres=np.array([[0.0, 0, 1.1], [0.5, 0, 0.9]])), _graph())
    s = rdmesh.ImplicitSurface.from_expression(
        "x**2 + y**2 + z**2 - 1", ((0, 0, 0), 2.0), features=given
    )
    with pytest.raises(FeatureError, match="not on the surface"):
        rdmesh.mesh_surface(s, radius_bound=0.2)


@pytest.mark.parametrize("options", [{"method": "topological-ball"}, {"certify": True}])
def test_given_balls_need_boissonnat_oudot_without_certify(options):
    given = ProtectingBalls(_balls(), _graph())
    s = rdmesh.ImplicitSurface.from_expression(
        "x**2 + y**2 + z**2 - 1", ((0, 0, 0), 2.0), features=given
    )
    with pytest.raises(ValueError, match="boissonnat-oudot"):
        rdmesh.mesh_surface(s, **options)
