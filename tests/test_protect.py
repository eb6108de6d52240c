"""Protecting balls (rdmesh.features.protect) and the weighted core: the
invariants hold on the balls themselves, the core keeps consecutive centres
as edges and never lets a ball hide a vertex."""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
from hypothesis import given, settings
from hypothesis import strategies as st
from rdmesh import core
from rdmesh.features.graph import build_graph, curve_of_polyline
from rdmesh.features.protect import protect
from rdmesh.refine.criteria import relaxed

CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
EDGES = [
    np.array([CORNERS[i], CORNERS[j]])
    for i in range(8)
    for j in range(i + 1, 8)
    if np.sum(CORNERS[i] != CORNERS[j]) == 1
]


def graph_of(polylines, radius=2.0):
    return build_graph(
        [curve_of_polyline(p, radius, f"features[{i}]", "given") for i, p in enumerate(polylines)],
        radius,
    )


def check_invariants(balls):
    """Consecutive balls overlap without holding each other's centre; every
    other pair is disjoint."""
    c, r = balls.centres, balls.radii
    i, j = balls.pairs[:, 0], balls.pairs[:, 1]
    d = np.linalg.norm(c[i] - c[j], axis=1)
    assert (d < r[i] + r[j]).all()
    assert (d > np.maximum(r[i], r[j])).all()
    dd = np.linalg.norm(c[:, None] - c[None], axis=2)
    near = dd <= r[:, None] + r[None, :]
    np.fill_diagonal(near, False)
    near[i, j] = near[j, i] = False
    assert not near.any()


@settings(max_examples=15, deadline=None)
@given(size=st.floats(0.03, 0.6), twist=st.floats(0.0, 1.0))
def test_balls_on_the_cube_edges_keep_the_invariants(size, twist):
    # A curved size field: smaller towards one corner.
    def field(x):
        return size * (1.0 - 0.5 * twist * np.linalg.norm(x - 1.0, axis=1) / 3.5)

    g = graph_of(EDGES)
    b = protect(g, field, 2.0)
    check_invariants(b)
    # Centres on the edges (the polylines), corners at the corners.
    on = (np.abs(np.abs(b.centres) - 1) <= 1e-12).sum(axis=1) >= 2
    assert on.all()
    assert np.array_equal(b.centres[b.corner >= 0], g.corners)
    # The spacing along each curve is at most the field (edge_size).
    p = b.pairs
    d = np.linalg.norm(b.centres[p[:, 0]] - b.centres[p[:, 1]], axis=1)
    mid = 0.5 * (b.centres[p[:, 0]] + b.centres[p[:, 1]])
    assert (d <= field(mid) * 1.25).all()


@settings(max_examples=15, deadline=None)
@given(angle=st.floats(10.0, 170.0))
def test_curves_meeting_at_small_angles_get_disjoint_balls(angle):
    a = np.radians(angle)
    o = np.zeros(3)
    g = graph_of([np.array([o, [1.0, 0, 0]]), np.array([o, [np.cos(a), np.sin(a), 0]])])
    b = protect(g, lambda x: np.full(len(x), 0.2), 2.0)
    check_invariants(b)


@pytest.mark.parametrize("h", [0.2, 0.15, 0.11])
def test_corners_near_42_degrees_are_protected(h):
    # Around 41-46 degrees the first ball out of the corner used to start a
    # dense step too far out, overlap the corner ball by less than the lens,
    # and each repair repeated the layout at a smaller scale down to the floor.
    o = np.zeros(3)
    for angle in np.r_[np.arange(38.0, 48.0, 0.2), 41.75]:
        a = np.radians(angle)
        g = graph_of([np.array([o, [1.0, 0, 0]]), np.array([o, [np.cos(a), np.sin(a), 0]])])
        check_invariants(protect(g, lambda x: np.full(len(x), h), 2.0))


@pytest.mark.parametrize(
    "angle, gap", [(12, 1e-2), (12, 1e-3), (15, 3e-3), (20, 3e-3), (20, 3e-4), (25, 1e-3)]
)
def test_a_small_angle_next_to_a_near_corner_is_protected(angle, gap):
    # Two curves leave each of two corners `gap` apart at a small angle (a
    # marching-cubes rim's step). A stretch shorter than the spacing got two
    # new balls at its ends, each holding the other's centre, and a pair short
    # of the lens a ball inside both: each round shrank a ball below the last,
    # down to the floor.
    a = np.radians(angle)
    o, q = np.zeros(3), np.array([0.0, 0.0, gap])
    curves = [
        np.array([o, [1.0, 0, 0]]),
        np.array([o, [np.cos(a), np.sin(a), 0]]),
        np.array([o, q]),
        np.array([q, [-1.0, 0, gap]]),
        np.array([q, [-np.cos(a), -np.sin(a), gap]]),
    ]
    b = protect(graph_of(curves), lambda x: np.full(len(x), 0.1), 2.0, distance=0.01)
    check_invariants(b)
    assert b.radii[b.corner >= 0].min() >= gap / 8


@pytest.mark.parametrize("narrow, step", [(0.05, 1e-3), (0.03, 1e-4), (0.3, 1e-4)])
def test_a_zigzag_with_narrow_teeth_and_steps_is_protected(narrow, step):
    # A marching-cubes rim's shape: teeth alternately wide and narrow (7-17
    # degrees at the narrow tips), with a small step at every third tip.
    pts = [np.zeros(3)]
    for i in range(12):
        tip = np.array([pts[-1][0] + (narrow if i % 2 else 0.5), 1.0, 0.0])
        pts.append(tip)
        if i % 3 == 0:
            pts.append(tip + [step, 0, step / 10])
        pts.append(np.array([pts[-1][0] + (narrow if i % 2 else 0.5), 0.0, 0.0]))
    pts = np.array(pts)
    g = graph_of([pts[i : i + 2] for i in range(len(pts) - 1)], radius=20.0)
    b = protect(g, lambda x: np.full(len(x), 0.3), 20.0, distance=0.03)
    check_invariants(b)
    assert b.radii.min() >= step / 4


@pytest.mark.parametrize("short", [0.03, 0.01, 0.003])
def test_balls_leaving_a_small_corner_ball_are_graded(short):
    # A corner kept small by a nearby corner (a short curve between them): the
    # long curve leaving it got balls of its full spacing right next to the
    # corner ball, which nearly met the short curve's balls, and refinement
    # squeezed triangles of 1 degree into the gap (a cut rim's corner).
    o = np.zeros(3)
    curves = [np.array([o, [short, 0, 0]]), np.array([o, [0, 1.0, 0]])]
    b = protect(graph_of(curves), lambda x: np.full(len(x), 0.2), 2.0)
    check_invariants(b)
    corner = int(np.flatnonzero((b.corner >= 0) & (np.linalg.norm(b.centres, axis=1) == 0))[0])
    chain = next(c for c in b.chains if c[0] == corner and b.centres[c[-1], 1] > 0.5)
    r = b.radii[chain]
    # Consecutive radii change by a bounded ratio from the corner on (16 and
    # 54 times before, for the two shorter curves).
    assert (np.maximum(r[1:], r[:-1]) <= 4.0 * np.minimum(r[1:], r[:-1])).all()


def test_a_ball_put_between_two_overlapping_along_the_curve_lies_between_them():
    # Two consecutive balls the repair finds apart in space but overlapping along
    # the arc (a bend, or points projected onto an exact curve): the new ball
    # must go between them, not behind one of them onto another ball.
    from rdmesh.features.protect import _assemble, _split, _State

    g = graph_of([np.array([[0.0, 0, 0], [1.0, 0, 0]])])
    c = g.curves[0]
    s = np.array([0.2, 0.4, 0.5])
    st = _State([s.copy()], [c.on_curve(s)], [np.array([0.05, 0.05, 0.5])], np.full(2, 0.01))
    balls = _assemble(g, st)
    first, second = balls.index[balls.pairs[:, 0]], balls.index[balls.pairs[:, 1]]
    k = np.flatnonzero((first == 1) & (second == 2))
    _split(balls, st, g, k, balls.radii.copy())
    new = np.setdiff1d(st.s[0], s)
    assert len(new) == 1 and 0.4 < new[0] < 0.5
    assert np.all(np.diff(st.s[0]) > 0)


def test_a_circle_is_one_closed_chain():
    t = np.linspace(0, 2 * np.pi, 200)
    circle = np.c_[np.cos(t), np.sin(t), np.zeros_like(t)]
    circle[-1] = circle[0]
    b = protect(graph_of([circle]), lambda x: np.full(len(x), 0.3), 2.0)
    check_invariants(b)
    assert len(b.chains) == 1 and b.chains[0][0] == b.chains[0][-1]
    # Centres on the polyline (a 199-gon inscribed in the unit circle).
    r = np.linalg.norm(b.centres, axis=1)
    assert r.max() <= 1 + 1e-12 and r.min() >= np.cos(np.pi / 199) - 1e-12


def test_the_distance_bound_shortens_the_chords():
    t = np.linspace(0, 2 * np.pi, 400)
    circle = 0.5 * np.c_[np.cos(t), np.sin(t), np.zeros_like(t)]
    circle[-1] = circle[0]
    b = protect(graph_of([circle]), lambda x: np.full(len(x), 0.3), 2.0, distance=1e-3)
    p = b.pairs
    mid = 0.5 * (b.centres[p[:, 0]] + b.centres[p[:, 1]])
    sagitta = 0.5 - np.linalg.norm(mid, axis=1)
    assert sagitta.max() <= 1e-3 * 1.05


def test_balls_too_close_to_protect_are_refused():
    g = graph_of([np.array([[0, 0, 0], [1.0, 0, 0]]), np.array([[0, 1e-8, 0.0], [1, 1e-8, 0]])])
    with pytest.raises(rdmesh.FeatureError, match="cannot protect"):
        protect(g, lambda x: np.full(len(x), 0.1), 2.0)


def test_the_core_keeps_consecutive_centres_as_edges():
    g = graph_of(EDGES)
    b = protect(g, lambda x: np.full(len(x), 0.2), 2.0)
    rdt = core.RestrictedDelaunay(np.zeros(3), 2.0)
    ids = rdt.insert(b.centres, b.weights)
    assert (ids >= 0).all()
    assert np.allclose(rdt.weights()[ids], b.weights)
    # Many samples on the cube's faces, none inside a ball.
    rng = np.random.default_rng(1)
    pts = rng.uniform(-1, 1, (4000, 3))
    axis = rng.integers(0, 3, 4000)
    pts[np.arange(4000), axis] = np.sign(rng.uniform(-1, 1, 4000))
    pts = pts[~b.inside(pts)]
    new = rdt.insert(pts)
    assert (new >= 0).all()
    rdt.check()  # a valid regular triangulation
    off, adj = rdt.neighbours(ids[b.pairs[:, 0]])
    for k, (_u, v) in enumerate(b.pairs):
        assert ids[v] in adj[off[k] : off[k + 1]]


def test_the_core_refuses_a_ball_that_hides_a_vertex():
    rdt = core.RestrictedDelaunay(np.zeros(3), 2.0)
    rdt.insert(np.array([[0.0, 0.0, 0.0]]))
    # A ball centred on a sample.
    with pytest.raises(ValueError, match="would hide"):
        rdt.insert(np.array([[0.0, 0.0, 0.0]]), np.array([0.25]))
    # A ball whose power cell swallows a sample's: the sample at the origin,
    # its neighbours' balls around it, then one more over it.
    ring = np.array([[0.3, 0, 0], [-0.3, 0, 0], [0, 0.3, 0], [0, -0.3, 0], [0, 0, 0.3]])
    rdt.insert(ring, np.full(5, 0.04))
    with pytest.raises(ValueError, match="would hide 1 vertices"):
        rdt.insert(np.array([[0.0, 0.0, -0.3]]), np.array([0.2]))
    with pytest.raises(ValueError, match="weight"):
        rdt.insert(np.array([[0.5, 0.0, 0.0]]), np.array([-1.0]))
    with pytest.raises(ValueError, match="weights must have shape"):
        rdt.insert(np.array([[0.5, 0.0, 0.0]]), np.array([1.0, 2.0]))


def test_a_sample_a_ball_hides_is_not_a_vertex():
    rdt = core.RestrictedDelaunay(np.zeros(3), 2.0)
    rdt.insert(np.array([[0.0, 0.0, 0.0]]), np.array([0.25]))
    # At the ball's centre (a smaller weight there is hidden); a point inside
    # the ball but not hidden (its power cell reaches out of the ball) is a
    # vertex, which is why seeds in balls are dropped before insertion.
    ids = rdt.insert(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.05], [1.0, 0.0, 0.0]]))
    assert ids[0] == -1 and ids[1] >= 0 and ids[2] >= 0
    assert rdt.number_of_samples == 3


def test_mesh_3_relaxation_next_to_balls():
    # One weighted vertex, its neighbours at 1.5 radii: the smallest sphere
    # orthogonal to the ball and a neighbour has (d^2 - w)^2 / (4 d^2) =
    # (2.25 - 1)^2 / 9 = 0.17 times w: below 0.64 and 1 (size, angle), above
    # 0.04 (distance).
    corners = np.array([[[0, 0, 0], [1.5, 0, 0], [0, 1.5, 0]]], float)
    w = np.array([[1.0, 0.0, 0.0]])
    r = relaxed(corners, w)
    assert r.size[0] and r.angle[0] and not r.distance[0] and not r.never[0]
    # Three balls sharing a point: never refined.
    corners = np.array([[[0, 0, 0], [1.0, 0, 0], [0.5, 0.8, 0]]])
    r = relaxed(corners, np.full((1, 3), 0.5))
    assert r.never[0]
    # No weight: nothing relaxed.
    r = relaxed(corners, np.zeros((1, 3)))
    assert not (r.size | r.angle | r.distance | r.never).any()


def test_protection_by_far_more_balls_than_the_curves_ask_for_is_refused():
    """Two parallel curves a hair apart need balls of the gap's size all along:
    past MAX_EXCESS times the balls their length asks for at the size bound,
    protection is refused with a FeatureError naming the count, not run for
    minutes; curves a tenth of the size bound apart are protected."""
    from rdmesh.features.graph import FeatureError

    def pair(gap):
        return graph_of(
            [np.array([[0.0, 0, 0], [1.0, 0, 0]]), np.array([[0, gap, 0], [1, gap, 0]])]
        )

    def size(x):
        return np.full(len(x), 0.2)

    check_invariants(protect(pair(0.02), size, 2.0))
    with pytest.raises(FeatureError, match=r"\d+ balls .* more than 1000 times"):
        protect(pair(1e-4), size, 2.0)


def test_the_angle_bound_is_held_next_to_small_balls_where_the_point_lands_out():
    """A 25-degree facet at a ball's centre: spared by Mesh_3's relaxation
    (20 degrees), held to 30 when the user chose small balls and the facet's
    surface ball is at least HOLD_RATIO ball radii, spared again below that
    (its refinement point would split the angle at the centre further)."""
    from rdmesh.refine.criteria import HOLD_RATIO, FacetCriteria

    rho, d, half = 0.1, 0.12, np.radians(12.5)
    corners = np.array([[[0, 0, 0], [d * np.cos(half), d * np.sin(half), 0],
                         [d * np.cos(half), -d * np.sin(half), 0]]])  # fmt: skip
    w = np.array([[rho**2, 0.0, 0.0]])
    centre = corners.mean(axis=1)

    def bad(hold, radius):
        c = FacetCriteria(30.0, 1.0, hold_at_small_balls=hold)
        return bool(c.bad(corners, centre, np.array([radius]), weights=w)[0])

    assert not bad(False, 0.1)
    assert bad(True, HOLD_RATIO * rho * 1.01)
    assert not bad(True, HOLD_RATIO * rho * 0.99)


def test_small_balls_leave_fewer_triangles_below_the_angle_bound():
    """Two spheres' union (a circular crease): with edge_size 0.3 times the
    radius bound (seeds kept 2 ball radii off), fewer triangles below 30
    degrees than with the default balls and a larger smallest angle (24.8
    degrees with seeds 1.2 radii off), the crease kept either way."""
    text = "min(sqrt((x-0.4)**2+y**2+z**2)-0.6, sqrt((x+0.4)**2+y**2+z**2)-0.6)"
    s = rdmesh.ImplicitSurface.from_expression(text, ((0, 0, 0), 2.0))
    kw = dict(radius_bound=0.1, distance_bound=0.01)
    default = rdmesh.mesh_surface(s, **kw)
    small = rdmesh.mesh_surface(s, edge_size=0.03, **kw)
    assert default.features.held and small.features.held
    assert (small.angles < 29.99).sum() < (default.angles < 29.99).sum()
    assert small.angles.min() > default.angles.min()
