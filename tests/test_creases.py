"""Creases and corners found automatically in expressions and CSG trees (issue 28).

The pieces of a tree (its min/max/abs branches), the search for creases
(seeds, tracing, corners, the interval pass), rdmesh.csg, and meshes that
keep what was found. Properties are recomputed from the outputs against the
exact curves.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import rdmesh
from hypothesis import given, settings
from hypothesis import strategies as st
from meshcheck import assert_good_mesh, euler_per_component
from rdmesh.creases import find_creases, piece_model
from rdmesh.features import FeatureError
from rdmesh.features.graph import build_graph
from rdmesh.surfaces import SURFACES
from rdmesh.surfaces.builtin import BUILTIN_EXPRESSIONS
from rdmesh.surfaces.expressions import parse_expression

BOX = "max(abs(x), abs(y), abs(z)) - 1"
BALL = "sqrt((x-1)**2 + (y-1)**2 + (z-1)**2) - 0.8"
BOX_BALL = f"min({BOX}, {BALL})"
CYLINDER = "max(x**2 + y**2 - 1, abs(z) - 1)"
LENS = "max(sqrt((x-0.5)**2+y**2+z**2)-1, sqrt((x+0.5)**2+y**2+z**2)-1)"
CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)


def surface(text, sphere=((0, 0, 0), 2.0), **kw):
    return rdmesh.ImplicitSurface.from_expression(text, sphere, **kw)


def segment_distance(p, a, b):
    """Distance from points ``p`` (n, 3) to the nearest of segments a[i]-b[i]."""
    d = b - a
    t = np.clip(np.einsum("nkj,kj->nk", p[:, None] - a[None], d) / np.einsum("kj,kj->k", d, d),
                0, 1)  # fmt: skip
    q = a[None] + t[..., None] * d[None]
    return np.linalg.norm(q - p[:, None], axis=2).min(axis=1)


def box_edges(rot=None):
    """The 12 edges of the cube [-1, 1]^3 mapped by x -> rot.T x, as (a, b)."""
    rot = np.eye(3) if rot is None else rot
    pairs = [(i, j) for i in range(8) for j in range(i + 1, 8)
             if np.sum(CORNERS[i] != CORNERS[j]) == 1]  # fmt: skip
    c = CORNERS @ rot
    return c[[i for i, _ in pairs]], c[[j for _, j in pairs]]


def curve_points(curves, n=40):
    """Points of the true curves (the polylines' points projected)."""
    return np.concatenate([c.on_curve(np.linspace(0, c.length, n)) for c in curves])


# -- pieces ------------------------------------------------------------------


PIECEWISE = [
    BOX,
    BOX_BALL,
    "min(x, y, z, 0.5) + abs(x - y) * max(y, z)",
    "abs(abs(x) - 0.5) + max(min(x, y), z**2) - 1",
    "max(x**2, 0.3) - min(abs(y), cos(z))",
]


@pytest.mark.parametrize("text", PIECEWISE)
def test_the_pieces_evaluate_the_expression_itself(text):
    e = parse_expression(text)
    p = np.random.default_rng(1).uniform(-2, 2, (500, 3))
    r = e.pieces.evaluate(p)
    assert np.array_equal(r.value, e(p))
    assert np.array_equal(r.grad, e.gradient(p))
    assert np.array_equal(e.pieces.value(p), e(p))


def test_labels_tell_the_faces_of_a_box_apart():
    model = parse_expression(BOX).pieces
    assert model.size == 5 and model.kinds == ["max", "max", "abs", "abs", "abs"]
    # The middles of the six faces.
    faces = np.vstack([np.eye(3), -np.eye(3)])
    label = model.evaluate(faces).label
    assert len({row.tobytes() for row in label}) == 6
    # Two points on one face carry the same label.
    same = model.evaluate(np.array([[1.0, 0.1, 0.2], [1.0, -0.3, 0.5]])).label
    assert np.array_equal(same[0], same[1])


def test_a_forced_branch_is_the_piece_beyond_the_switch():
    model = parse_expression("max(x, y)").pieces
    p = np.array([[2.0, 1.0, 0.0]])
    free, forced = model.evaluate(p), model.evaluate(p, np.array([1]))
    assert free.value[0] == 2.0 and free.choice[0, 0] == 0
    assert forced.value[0] == 1.0 and np.array_equal(forced.grad[0], [0, 1, 0])
    assert forced.natural[0, 0] == 0  # it would take x on its own
    assert forced.switch[0, 0] == 1.0 and np.array_equal(forced.switch_grad[0, 0], [1, -1, 0])


# -- found creases -------------------------------------------------------------


def test_a_box_has_12_edges_and_8_corners_exactly():
    found = find_creases(surface(BOX))
    graph = build_graph(found.curves, 2.0)
    assert len(graph.curves) == 12 and len(graph.corners) == 8
    assert np.abs(np.sort(graph.corners, axis=0) - np.sort(CORNERS, axis=0)).max() <= 1e-15
    assert segment_distance(curve_points(found.curves), *box_edges()).max() <= 1e-12
    assert found.level == "intervals" and found.boxes["unresolved"] == 0
    assert len(found.unresolved) == 0


def test_a_rotated_box_has_12_edges_and_8_corners_within_1e_12():
    from scipy.spatial.transform import Rotation

    rot = Rotation.from_euler("xyz", [0.3, -0.5, 0.7]).as_matrix()
    rows = [f"abs({r[0]!r}*x + {r[1]!r}*y + {r[2]!r}*z)" for r in rot.tolist()]
    found = find_creases(surface(f"max({', '.join(rows)}) - 1"))
    graph = build_graph(found.curves, 2.0)
    assert len(graph.curves) == 12 and len(graph.corners) == 8
    exact = CORNERS @ rot
    assert np.linalg.norm(graph.corners[:, None] - exact[None], axis=2).min(axis=1).max() <= 1e-12
    assert segment_distance(curve_points(found.curves), *box_edges(rot)).max() <= 1e-12


def test_box_and_ball_have_15_curves_10_corners_and_exact_arcs():
    found = find_creases(surface(BOX_BALL, ((0.2, 0.2, 0.2), 2.4)))
    graph = build_graph(found.curves, 2.4)
    assert len(graph.curves) == 15 and len(graph.corners) == 10
    cut = np.array([[1, 1, 0.2], [1, 0.2, 1], [0.2, 1, 1]])
    assert np.linalg.norm(graph.corners[:, None] - cut[None], axis=2).min(axis=0).max() <= 1e-15
    # Every curve point is on the box and on the ball, or on two box faces.
    x = curve_points(found.curves)
    box = np.abs(x).max(axis=1) - 1
    ball = np.linalg.norm(x - 1, axis=1) - 0.8
    arcs = np.abs(ball) <= 1e-12
    assert np.abs(box).max() <= 1e-12
    assert arcs.sum() > 0 and segment_distance(x[~arcs], *box_edges()).max() <= 1e-12
    # On an arc, one coordinate is 1 and the others within the ball.
    assert np.all((np.abs(x[arcs] - 1) <= 1e-12).any(axis=1))


@pytest.mark.parametrize(
    "text, loops, radius, height",
    [(CYLINDER, 2, 1.0, 1.0), (LENS, 1, np.sqrt(0.75), 0.0)],
)
def test_cylinder_and_lens_have_their_circles(text, loops, radius, height):
    found = find_creases(surface(text))
    assert len(found.curves) == loops and all(c.closed for c in found.curves)
    x = curve_points(found.curves)
    if text == CYLINDER:
        r, h = np.hypot(x[:, 0], x[:, 1]), np.abs(x[:, 2])
    else:
        r, h = np.hypot(x[:, 1], x[:, 2]), np.abs(x[:, 0])
    assert np.abs(r - radius).max() <= 1e-12 and np.abs(h - height).max() <= 1e-12


def test_a_small_loop_between_the_grid_points_is_found_by_the_interval_pass():
    # A bump of radius 0.015 centred on a face: its crease loop (the same
    # radius) is smaller than the grid's cell (0.0625), and no pair of
    # crossings brackets it (for this seed).
    s = surface(f"min({BOX}, sqrt((x-1)**2 + (y-0.3)**2 + (z+0.2)**2) - 0.015)")
    sampled = find_creases(s, intervals=False)
    proven = find_creases(s)
    loops = [c for c in proven.curves if c.closed]
    assert len(proven.curves) == 13 and len(loops) == 1 and proven.boxes["unresolved"] == 0
    assert len(sampled.curves) == 12 and not any(c.closed for c in sampled.curves)
    x = curve_points(loops)
    assert np.abs(x[:, 0] - 1).max() <= 1e-12
    assert np.abs(np.linalg.norm(x - [1, 0.3, -0.2], axis=1) - 0.015).max() <= 1e-12


def test_touching_spheres_are_reported_unresolved_not_traced():
    s = surface("min(sqrt(x**2+y**2+z**2)-1, sqrt((x-2)**2+y**2+z**2)-1)", ((1, 0, 0), 2.6))
    found = find_creases(s)
    assert found.curves == []
    assert len(found.unresolved) == 1 and np.abs(found.unresolved[0] - [1, 0, 0]).max() < 1e-3
    assert found.boxes["unresolved"] > 0


def test_a_tie_with_parallel_gradients_is_a_smooth_join():
    # max(x, 0)**2 switches on x = 0 with the same gradient on both sides.
    found = find_creases(surface("x**2 + y**2 + z**2 + 3*max(x, 0)**2 - 1", ((0, 0, 0), 1.5)))
    assert found.curves == [] and found.boxes["smooth"] > 0 and found.boxes["unresolved"] == 0


def test_ties_away_from_the_surface_are_excluded_by_intervals():
    # Two disjoint spheres: min switches between them, never on the surface.
    found = find_creases(surface("min(x**2+y**2+z**2-1, (x-1.3)**2+(y-0.1)**2+z**2-0.01**2)"))
    assert found.curves == [] and found.boxes["unresolved"] == 0 and found.boxes["smooth"] == 0
    assert found.boxes["traced"] == 0 and found.boxes["excluded"] > 0


@pytest.mark.parametrize("name", sorted(SURFACES))
def test_no_crease_on_the_public_smooth_surfaces(name):
    assert piece_model(SURFACES[name].make()) is None  # a plain function: nothing to search
    s = surface(BUILTIN_EXPRESSIONS[name], SURFACES[name].make().bounding_sphere)
    assert find_creases(s) is None  # no min, max or abs


_CENTRES = st.tuples(*[st.floats(-0.6, 0.6)] * 3)


@st.composite
def smooth_expressions(draw):
    """Random smooth shapes: spheres and ellipsoids blended by smooth
    minima and maxima, bumps, and max(u, 0)**2 terms (C1 joins)."""
    parts = []
    for _ in range(draw(st.integers(2, 3))):
        (a, b, c), r = draw(_CENTRES), draw(st.floats(0.4, 0.9))
        if draw(st.booleans()):
            parts.append(f"sqrt((x-{a!r})**2 + (y-{b!r})**2 + (z-{c!r})**2) - {r!r}")
        else:
            p, q = draw(st.floats(0.5, 1.5)), draw(st.floats(0.5, 1.5))
            parts.append(
                f"(((x-{a!r})/{p!r})**2 + ((y-{b!r})/{q!r})**2 + (z-{c!r})**2 - {r!r}**2)"
            )
    out = parts[0]
    for p in parts[1:]:
        k = draw(st.floats(0.1, 0.5))
        m = draw(st.sampled_from(["min", "max"]))
        s = "" if m == "min" else "-"
        a, b = f"{s}({out})", f"{s}({p})"
        out = f"{s}(min({a}, {b}) - max({k!r} - abs({a} - {b}), 0)**2/(4*{k!r}))"
    if draw(st.booleans()):
        out += f" + {draw(st.floats(0.1, 1.0))!r}*max(x - {draw(st.floats(-0.5, 0.5))!r}, 0)**2"
    return out


@settings(max_examples=12, deadline=None)
@given(smooth_expressions())
def test_no_crease_on_random_smooth_expressions(text):
    s = surface(text, ((0, 0, 0), 3.0))
    try:
        found = find_creases(s)
    except rdmesh.RdmeshError:
        return
    assert found.curves == []


@pytest.mark.parametrize("text", ["floor(x) + y**2 + z**2 - 1", "sign(x)*x + y**2 + z**2 - 1",
                                  "min(ceil(2*x), 1) + y**2 + z**2 - 1"])  # fmt: skip
def test_steps_are_refused_where_creases_are_searched(text):
    with pytest.raises(FeatureError, match="features='none'"):
        surface(text)
    surface(text, features="none")  # accepted without the search
    surface("floor(2.5) + x**2 + y**2 + z**2 - 4")  # a constant step is a number


# -- rdmesh.csg ---------------------------------------------------------------------------


def np_sphere(c, r):
    c = np.asarray(c, float)
    return rdmesh.ImplicitSurface(
        lambda p: np.linalg.norm(p - c, axis=1) - r, (c, r + 0.5),
        gradient=lambda p: (p - c) / np.linalg.norm(p - c, axis=1)[:, None],
    )  # fmt: skip


def test_csg_of_expressions_is_an_expression():
    a, b = surface("sqrt(x**2+y**2+z**2) - 1"), surface(BALL)
    p = np.random.default_rng(0).uniform(-2, 2, (300, 3))
    for op, ref in ((rdmesh.csg.union, np.minimum), (rdmesh.csg.intersection, np.maximum)):
        s = op(a, b)
        assert isinstance(s.f, rdmesh.surfaces.expressions.Expression)
        assert np.array_equal(s(p), ref(a(p), b(p)))
    d = rdmesh.csg.difference(a, b)
    assert np.array_equal(d(p), np.maximum(a(p), -b(p)))


def test_csg_of_callables_evaluates_each_operand_and_its_gradient():
    a, b = np_sphere((0, 0, 0), 1.0), np_sphere((1.2, 0, 0), 0.7)
    u = rdmesh.csg.union(a, b)
    p = np.random.default_rng(0).uniform(-2, 2, (300, 3))
    assert np.array_equal(u(p), np.minimum(a(p), b(p)))
    first = a(p) <= b(p)
    assert np.array_equal(u.grad(p)[first], a.grad(p)[first])
    assert np.array_equal(u.grad(p)[~first], b.grad(p)[~first])
    # The crease circle where the spheres meet, each point on both spheres.
    found = find_creases(u)
    assert len(found.curves) == 1 and found.curves[0].closed and found.level == "sampled"
    x = curve_points(found.curves)
    assert np.abs(a(x)).max() <= 1e-12 and np.abs(b(x)).max() <= 1e-12


def test_csg_bounding_spheres():
    a, b = np_sphere((0, 0, 0), 1.0), np_sphere((2, 0, 0), 0.5)  # spheres of radius 1.5 and 1
    c, r = rdmesh.csg.union(a, b).bounding_sphere
    assert np.linalg.norm(c - [0, 0, 0]) + 1.5 <= r * (1 + 1e-9)
    assert np.linalg.norm(c - [2, 0, 0]) + 1.0 <= r * (1 + 1e-9)
    assert r <= 2.25 + 1e-9  # the smallest sphere around both
    assert rdmesh.csg.intersection(a, b).radius == 1.0
    assert rdmesh.csg.difference(a, b).radius == 1.5
    assert rdmesh.csg.smooth_union(a, b, 0.2).radius == pytest.approx(r + 0.2)
    assert rdmesh.csg.union(a, b, bounding_sphere=((1, 0, 0), 3.0)).radius == 3.0


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda a, b: rdmesh.csg.union(a), "at least two"),
        (lambda a, b: rdmesh.csg.union(a, np.max), "operand 1 must be an rdmesh.ImplicitSurface"),
        (
            lambda a, b: rdmesh.csg.intersection(
                a,
                rdmesh.ImplicitSurface(b.f, b.bounding_sphere, clip_box=[(-1, -1, -1), (1, 1, 1)]),
            ),
            "clip box",
        ),  # fmt: skip
        (
            lambda a, b: rdmesh.csg.union(
                a,
                rdmesh.ImplicitSurface(b.f, b.bounding_sphere, features=[[(0, 0, 1), (0, 1, 0)]]),
            ),
            "given feature curves",
        ),  # fmt: skip
        (lambda a, b: rdmesh.csg.smooth_union(a, b, 0.0), "k must be"),
    ],
)
def test_csg_bad_operands(call, match):
    a, b = np_sphere((0, 0, 0), 1.0), np_sphere((1, 0, 0), 1.0)
    with pytest.raises(ValueError, match=match):
        call(a, b)


@pytest.mark.parametrize("expression", [True, False])
def test_smooth_variants_make_no_crease(expression):
    if expression:
        a, b = surface("sqrt(x**2+y**2+z**2) - 1"), surface("sqrt((x-1.2)**2+y**2+z**2) - 0.7")
    else:
        a, b = np_sphere((0, 0, 0), 1.0), np_sphere((1.2, 0, 0), 0.7)
    p = np.random.default_rng(0).uniform(-2, 2, (300, 3))
    for op in (rdmesh.csg.smooth_union, rdmesh.csg.smooth_intersection,
               rdmesh.csg.smooth_difference):  # fmt: skip
        s = op(a, b, 0.3)
        assert find_creases(s).curves == []
    # Equal to min far from the join, below it by at most k / 4 near it.
    u = rdmesh.csg.smooth_union(a, b, 0.3)
    m = np.minimum(a(p), b(p))
    assert np.all(u(p) <= m) and np.all(u(p) >= m - 0.3 / 4 - 1e-12)
    far = np.abs(a(p) - b(p)) >= 0.3
    assert np.array_equal(u(p)[far], m[far])


# -- meshes -----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def box_mesh():
    return rdmesh.mesh_surface(surface(BOX), radius_bound=0.1, distance_bound=0.01)


def test_an_expression_box_keeps_its_creases_exactly(box_mesh):
    m = box_mesh
    s = surface(BOX)
    assert_good_mesh(m, s.f, s.f.gradient, 2.0, euler=[2], distance_bound=0.01, sizing=0.1)
    assert m.features.held and len(m.features.curves) == 12 and len(m.features.corners) == 8
    on = np.concatenate(m.features.curves)
    assert segment_distance(m.vertices[on], *box_edges()).max() <= 1e-12
    corners = m.vertices[m.features.corners]
    assert np.abs(np.sort(corners, axis=0) - np.sort(CORNERS, axis=0)).max() == 0
    rep = m.report["creases"]
    assert rep["curves"] == 12 and rep["corners"] == 8
    assert rep["level"] == "intervals" and rep["unresolved"] == []
    assert m.report["features"]["sources"] == ["crease"]


def test_features_none_keeps_the_old_chamfered_box(box_mesh):
    m = rdmesh.mesh_surface(surface(BOX, features="none"), radius_bound=0.1, distance_bound=0.01)
    assert m.features is None and "creases" not in m.report
    assert len(m.vertices) != len(box_mesh.vertices)


def test_a_smooth_expression_gives_the_same_mesh_as_before():
    text = "min(x**2+y**2+z**2-1, (x-1.3)**2+(y-0.1)**2+z**2-0.05**2)"
    kw = dict(radius_bound=0.1, distance_bound=0.02)
    auto = rdmesh.mesh_surface(surface(text), **kw)
    none = rdmesh.mesh_surface(surface(text, features="none"), **kw)
    assert np.array_equal(auto.vertices, none.vertices)
    assert np.array_equal(auto.faces, none.faces)
    assert auto.report["creases"]["curves"] == 0 and auto.features is None


def test_topological_ball_meshes_creases_by_boissonnat_oudot_and_says_so():
    m = rdmesh.mesh_surface(surface(CYLINDER), method="topological-ball", radius_bound=0.15)
    assert m.stats["method"] == "boissonnat-oudot" and not m.topology_certified
    assert "instead of 'topological-ball' with certify" in m.report["creases"]["note"]
    assert m.features.held and len(m.features.curves) == 2


def test_a_holed_box_from_numpy_functions_is_genus_1_with_its_creases():
    slabs = [rdmesh.ImplicitSurface(lambda p, a=a, w=w: np.abs(p[:, a]) - w, ((0, 0, 0), 3.0))
             for a, w in ((0, 1.0), (1, 1.0), (2, 0.5))]  # fmt: skip
    rod = rdmesh.ImplicitSurface(lambda p: np.hypot(p[:, 0], p[:, 1]) - 0.4, ((0, 0, 0), 3.0))
    holed = rdmesh.csg.difference(rdmesh.csg.intersection(*slabs), rod,
                                  bounding_sphere=((0, 0, 0), 1.8))  # fmt: skip
    m = rdmesh.mesh_surface(holed, radius_bound=0.12, distance_bound=0.015)
    assert m.is_closed_manifold() and euler_per_component(m.faces, len(m.vertices)) == [0]
    assert m.features.held and len(m.features.curves) == 14 and len(m.features.corners) == 8
    rims = [c for c in m.features.curves if c[0] == c[-1]]
    assert len(rims) == 2
    x = m.vertices[np.concatenate(rims)]
    assert np.abs(np.hypot(x[:, 0], x[:, 1]) - 0.4).max() <= 1e-12
    assert np.abs(np.abs(x[:, 2]) - 0.5).max() <= 1e-12


def test_cli_finds_the_creases_of_an_expression_and_no_features_turns_it_off(tmp_path, capsys):
    from rdmesh import cli

    args = ["mesh", CYLINDER, "--bound", "2", "--radius", "0.2", "--distance", "0.02", "--quiet"]
    assert cli.main([*args, "-o", str(tmp_path / "a.ply")]) == 0
    text = capsys.readouterr().out
    assert "creases found: 2 curves, 0 corners (the interval search settled" in text
    assert "features: 2 curves, 0 corners kept" in text
    assert cli.main([*args, "-o", str(tmp_path / "b.ply"), "--no-features"]) == 0
    text = capsys.readouterr().out
    assert "creases found" not in text and "features:" not in text


def test_newton_iterates_that_run_off_are_degenerate_not_an_overflow():
    """A Gauss-Newton iterate whose gradients overflow (a random smooth
    expression's crease search did this, 2026-12-04) reads as degenerate and
    not converged, with no floating-point warning."""
    from rdmesh.creases.tracing import min_norm_step, residual

    g = np.array([[1.0, 2.0], [0.5, -0.5]])
    J = np.array([[[1e200, 0.0, 0.0], [0.0, 1e200, 0.0]], [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0]]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        step, sine = min_norm_step(g, J)
        r = residual(g, J)
    assert np.array_equal(step[0], [0.0, 0.0, 0.0]) and sine[0] == 0.0
    assert r[0] == np.inf
    assert sine[1] > 0.99 and np.allclose(step[1], [-0.5, 0.25, 0.0])
    assert r[1] == pytest.approx(0.5)
