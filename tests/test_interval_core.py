"""The core's interval evaluator, subdivision, root isolation and cell pruning,
against their numpy reference (tests/interval_reference.py).

The containment tests of every rule run on both evaluators in test_intervals.py;
these check what is particular to the core: that it agrees with the reference
rules on every function, that splitting the work over threads changes nothing,
and its errors.
"""

from __future__ import annotations

from contextlib import contextmanager, nullcontext
from fractions import Fraction

import interval_reference as reference
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rdmesh.core import INTERVAL_OPS, boxes_outside_cells, evaluate_intervals
from rdmesh.surfaces import intervals
from rdmesh.surfaces.builtin import BUILTIN_EXPRESSIONS
from rdmesh.surfaces.expressions import parse_expression
from rdmesh.surfaces.interval_program import compile_program
from rdmesh.surfaces.ir import NARY, UNARY
from rdmesh.topology import proven_cells
from scipy.spatial import Delaunay

HARD = [
    "min(sqrt(x**2+y**2+z**2)-1, sqrt((x-1.5)**2+(y-0.3)**2+(z-0.2)**2)-0.02)",
    "sin(3*x)*cos(3*y) + sin(3*y)*cos(3*z) + sin(3*z)*cos(3*x)",
    "abs(x) + max(y, z**3, -x) - log(1 + x**2)/(y - 0.5) + exp(-x**2)*z**(-2) + y**0.5",
]


def _boxes(rng, n, spread=2.0):
    c = rng.uniform(-spread, spread, (n, 3))
    w = rng.choice([0.0, 1e-9, 1e-3, 0.05, 0.5], (n, 3))
    return c - w, c + w


#: Every function of the grammar, on composite arguments (min, max and hypot
#: with three: the core folds them two at a time).
FUNCTION_CALLS = [
    *(f"{name}(x*y + 0.5) - 2*{name}(z)" for name in UNARY),
    *(f"{name}(x - z, y*x, 0.3 - y)" for name in NARY if NARY[name][1] is None),
    "atan2(y, x) - z",
    "atan2(x*y - 1, z)",
    "pow(x, y) + pow(y*y + 0.1, z)",
    "x**y + z",
    "(x*x)**(y - z)",
]


@contextmanager
def reference_rules():
    """The numpy reference in place of the core, for bounds and subdivision."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(intervals, "_bounds", reference.bounds)
        mp.setattr(proven_cells, "_subdivide", reference.subdivide)
        yield


def test_opcodes_come_from_the_core():
    ops, _ = compile_program(parse_expression("hypot(x, y, z) - atan2(y, x)**2")._root)
    names = {v: k for k, v in INTERVAL_OPS.items()}
    assert [names[o] for o in ops[:, 0]] == [
        "var", "var", "hypot", "var", "hypot", "var", "var", "atan2", "powc", "sub",
    ]  # fmt: skip
    assert sorted(INTERVAL_OPS.values()) == list(range(len(INTERVAL_OPS)))


@pytest.mark.parametrize("text", [*BUILTIN_EXPRESSIONS.values(), *HARD, *FUNCTION_CALLS])
@pytest.mark.parametrize("mean_value", [False, True])
def test_core_agrees_with_the_reference_rules(text, mean_value):
    rng = np.random.default_rng(7)
    lo, hi = _boxes(rng, 3000)
    expr = parse_expression(text)
    core = intervals.interval_gradient(expr, lo, hi, mean_value=mean_value)
    with reference_rules():
        ref = intervals.interval_gradient(expr, lo, hi, mean_value=mean_value)
    assert np.array_equal(core.undefined, ref.undefined)
    # Same rules, rounded a little differently: a few ulps of the bounds' size.
    for a, b in ((core.lo, ref.lo), (core.hi, ref.hi), (core.glo, ref.glo), (core.ghi, ref.ghi)):
        assert np.array_equal(np.isfinite(a), np.isfinite(b))
        fin = np.isfinite(a)
        scale = np.abs(b[fin]) + 1.0
        assert (np.abs(a[fin] - b[fin]) <= 1e-12 * scale).all()


def test_splitting_the_boxes_over_threads_changes_nothing():
    expr = parse_expression(BUILTIN_EXPRESSIONS["blob_line"])
    ops, consts = compile_program(expr._root)
    lo, hi = _boxes(np.random.default_rng(1), 20_000)
    whole = evaluate_intervals(ops, consts, lo, hi, True, True)
    parts = [evaluate_intervals(ops, consts, lo[i : i + 300], hi[i : i + 300], True, True)
             for i in range(0, len(lo), 300)]  # fmt: skip
    for k in range(5):
        assert np.array_equal(whole[k], np.concatenate([p[k] for p in parts]))


@pytest.mark.parametrize(
    ("ops", "consts", "match"),
    [
        ([[99, -1, -1]], [0.0], "unknown opcode"),
        ([[1, 3, -1]], [0.0], "axis"),
        ([[1, 0, -1], [3, 0, 1]], [0.0, 0.0], "earlier register"),
        ([[1, 0, -1], [2, 5, -1]], [0.0, 0.0], "earlier register"),
        (np.zeros((0, 3), np.int32), np.zeros(0), "empty"),
        ([[1, 0, -1]], [0.0, 1.0], "consts"),
        ([[1, 0]], [0.0], "shape"),
    ],
)
def test_bad_programs_raise(ops, consts, match):
    lo = np.zeros((2, 3))
    with pytest.raises(ValueError, match=match):
        evaluate_intervals(np.asarray(ops, np.int32), np.asarray(consts), lo, lo + 1, True, False)


# -- cell pruning ------------------------------------------------------------------------


def _outside_reference(lo, hi, owner, points, offsets, neighbour, skip=None):
    """The numpy rule the core replaced (proven_cells before issue 13's speed-up)."""
    out = np.zeros(len(lo), bool)
    for i in range(len(lo)):
        p = points[owner[i]]
        for q_id in neighbour[offsets[owner[i]] : offsets[owner[i] + 1]]:
            if skip is not None and q_id == skip[i]:
                continue
            w = points[q_id] - p
            a = np.where(w > 0, lo[i], hi[i]) @ w
            c = (0.5 * (p + points[q_id])) @ w
            if a > c + 1e-12 * (abs(c) + np.linalg.norm(w) * np.linalg.norm(p)):
                out[i] = True
                break
    return out


def _neighbours(points):
    indptr, indices = Delaunay(points).vertex_neighbor_vertices
    return indptr.astype(np.int64), indices.astype(np.int64)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), with_skip=st.booleans())
def test_cell_pruning_matches_the_bisector_rule(seed, with_skip):
    rng = np.random.default_rng(seed)
    points = rng.uniform(-1, 1, (40, 3))
    offsets, neighbour = _neighbours(points)
    owner = rng.integers(0, 40, 200)
    c = rng.uniform(-1.2, 1.2, (200, 3))
    w = rng.uniform(0, 0.3, (200, 3))
    lo, hi = c - w, c + w
    skip = neighbour[offsets[owner]] if with_skip else None
    got = boxes_outside_cells(lo, hi, owner, points, offsets, neighbour, skip).view(bool)
    ref = _outside_reference(lo, hi, owner, points, offsets, neighbour, skip)
    assert np.array_equal(got, ref)
    # A box holding its owner's sample is never outside the owner's cell.
    inside = ((lo <= points[owner]) & (points[owner] <= hi)).all(axis=1)
    assert not got[inside].any()


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"owner": np.array([40])}, "owner ids"),
        ({"owner": np.array([0, 1])}, "owner"),
        ({"neighbour_shift": 100}, "neighbour ids"),
        ({"offsets": np.zeros(3, np.int64)}, "offsets"),
        ({"skip": np.array([0, 1])}, "skip"),
    ],
)
def test_cell_pruning_rejects_bad_ids(change, match):
    points = np.random.default_rng(0).uniform(-1, 1, (40, 3))
    offsets, neighbour = _neighbours(points)
    args = {"owner": np.array([0]), "offsets": offsets, "skip": None}
    args.update({k: v for k, v in change.items() if k != "neighbour_shift"})
    if "neighbour_shift" in change:
        neighbour = neighbour + change["neighbour_shift"]
    lo = np.zeros((1, 3))
    with pytest.raises(ValueError, match=match):
        boxes_outside_cells(lo, lo + 0.1, args["owner"], points, args["offsets"], neighbour,
                            args["skip"])  # fmt: skip


@pytest.mark.parametrize("n", range(3, 18))
def test_integer_powers_hold_the_exact_power(n, evaluator_both):
    # The core multiplies small powers out (the numpy rules call pow): on point
    # boxes both must hold the exact rational power, over many magnitudes.
    rng = np.random.default_rng(n)
    x = rng.choice([-1.0, 1.0], 300) * 10.0 ** rng.uniform(-40, 40, 300)
    x = np.concatenate([x, rng.uniform(-3, 3, 100), [0.0, -0.0, 1.0, -1.0, 2.0**-537]])
    p = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    r = intervals.interval_gradient(parse_expression(f"x**{n}"), p, p)
    for xi, lo, hi, glo, ghi in zip(x, r.lo, r.hi, r.glo[:, 0], r.ghi[:, 0], strict=True):
        assert _holds(lo, hi, Fraction(float(xi)) ** n)
        assert _holds(glo, ghi, n * Fraction(float(xi)) ** (n - 1))


def _holds(lo: float, hi: float, exact: Fraction) -> bool:
    """lo <= exact <= hi, in exact arithmetic (infinite bounds hold everything beyond)."""
    return (lo == -np.inf or Fraction(lo) <= exact) and (hi == np.inf or exact <= Fraction(hi))


@pytest.fixture(params=["core", "reference"])
def evaluator_both(request, monkeypatch):
    if request.param == "reference":
        monkeypatch.setattr(intervals, "_bounds", reference.bounds)
    return request.param


# -- the proven tests' subdivision ---------------------------------------------------------


def _cell_case(text, seed, n):
    """A core holding ``n`` random points near the surface ``text`` (radius 2)
    and what the proven loop and silhouette tests need."""
    import rdmesh
    from rdmesh import core
    from rdmesh.topology.proven_cells import CellGeometry
    from scipy.spatial import cKDTree

    s = rdmesh.ImplicitSurface.from_expression(text, ((0, 0, 0), 2.0))
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1.3, 1.3, (40 * n, 3))
    x = x[np.argsort(np.abs(s(x)))[:n]]
    rdt = core.RestrictedDelaunay(s.centre, s.radius)
    rdt.insert(x)
    v = rdt.samples()
    g = s.grad(v)
    normals = g / np.maximum(np.linalg.norm(g, axis=1), 1e-300)[:, None]
    return s, rdt, v, normals, CellGeometry.of(rdt, v, s.centre, s.radius), cKDTree(v)


@pytest.mark.parametrize("seed", [0])
@pytest.mark.parametrize("n", [2, 12, 60])
@pytest.mark.parametrize(
    "text",
    [
        "x**2 + y**2 + z**2 - 1",
        "(sqrt(x**2 + y**2) - 0.8)**2 + z**2 - 0.09",
        "x**2/1.44 + y**2 + z**2/0.49 + 0.3*sin(4*x) - 1",
    ],
)
def test_core_subdivision_fails_the_same_facets_and_cells_as_the_reference(seed, text, n):
    # Whether an owner fails does not depend on the order boxes are taken in,
    # so the core's depth-first run and the reference's level-by-level run
    # must fail exactly the same facets and cells.
    from rdmesh.topology.proven_cells import prove_cells, proven_loop_test

    s, rdt, v, normals, geo, tree = _cell_case(text, seed, n)
    cells = np.arange(len(v))
    runs = {}
    for native in (True, False):
        with nullcontext() if native else reference_rules():
            loop = proven_loop_test(s, v, geo, tree)
            proof = prove_cells(s, rdt, v, normals, geo, tree, cells)
            # The loop proof again, from the proven cells' leaves.
            seeded = proven_loop_test(s, v, geo, tree, cells=proof)
        runs[native] = (loop, proof.violations, seeded)
    for a, b in zip(runs[True], runs[False], strict=True):
        assert np.array_equal(np.sort(a.owners), np.sort(b.owners))
        # Each refinement point is on the surface (or reported as unplaced).
        assert len(a.centres) + len(a.stuck) == len(a.owners) == a.count
        assert np.all(np.abs(s(a.centres)) <= 1e-6)
    # Two samples split the surface into two big patches, each with a silhouette.
    if n == 2:
        assert len(runs[True][1].owners) > 0


@pytest.mark.parametrize("native", [True, False])
@pytest.mark.parametrize(
    "text",
    ["(sqrt(x**2 + y**2) - 0.8)**2 + z**2 - 0.09", "x**2/1.44 + y**2 + z**2/0.49 - 1"],
)
def test_proven_cells_leaves_hold_every_surface_point_of_the_cell(text, native):
    # The loop proof starts from a proven cell's leaves, so they must hold
    # all of the cell's part of the surface: put many points on the surface,
    # each in the cell of its nearest sample, and find each in a leaf.
    from rdmesh.topology.proven_cells import prove_cells

    s, rdt, v, normals, geo, tree = _cell_case(text, 1, 60)
    with nullcontext() if native else reference_rules():
        proof = prove_cells(s, rdt, v, normals, geo, tree, np.arange(len(v)))
    assert proof.seeded.sum() >= 10  # enough proven cells to test
    rng = np.random.default_rng(5)
    x = rng.uniform(-1.3, 1.3, (40000, 3))
    for _ in range(30):  # Newton onto the surface
        g = s.grad(x)
        x = x - (s(x) / np.maximum(np.einsum("ij,ij->i", g, g), 1e-300))[:, None] * g
    x = x[(np.abs(s(x)) < 1e-12) & (np.linalg.norm(x, axis=1) < 1.9)]
    _, owner = tree.query(x)
    keep = proof.seeded[owner]
    x, owner = x[keep], owner[keep]
    assert len(x) > 1000
    for p in np.unique(owner):
        lo = proof.lo[proof.first[p] : proof.first[p + 1]]
        hi = proof.hi[proof.first[p] : proof.first[p + 1]]
        pts = x[owner == p]
        inside = np.all((pts[:, None] >= lo[None]) & (pts[:, None] <= hi[None]), axis=2)
        assert inside.any(axis=1).all(), f"a surface point of proven cell {p} is in no leaf"


def _prove_args(budget=1 << 16, **change):
    s, _, v, normals, geo, _ = _cell_case("x**2 + y**2 + z**2 - 1", 3, 40)
    ops, consts = compile_program(s.f._root)
    box = np.array([-1.0, -1.0, -1.0]), np.array([1.0, 1.0, 1.0])
    n = len(v)
    args = {
        "ops": ops, "consts": consts,
        "lo": np.tile(box[0], (n, 1)), "hi": np.tile(box[1], (n, 1)),
        "cell": np.arange(n), "direction": normals, "floor": np.full(n, 1e-3),
        "points": v, "offsets": geo.offsets, "neighbour": geo.neighbour,
        "budget": budget,
    }  # fmt: skip
    args.update(change)
    return args


def test_core_subdivision_budget_makes_owners_fail():
    from rdmesh.core import prove_boxes

    failed, lo, hi, boxes = prove_boxes(**_prove_args())
    assert not failed.any()  # 40 samples on the unit sphere: every cell proven
    assert (boxes > 1).all()
    # With one box each, no cell can be proven from the whole cube: all fail,
    # each at its first box.
    failed, lo, hi, boxes = prove_boxes(**_prove_args(budget=1))
    assert failed.all() and (boxes == 1).all()
    assert np.allclose(lo, -1.0) and np.allclose(hi, 1.0)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"floor": np.zeros(1)}, "floor"),
        ({"budget": 0}, "budget"),
        ({"cell": np.full(1, 10**6)}, "cell ids"),
        ({"lo": np.full((1, 3), np.nan)}, "finite"),
        ({"lo": np.full((1, 3), 2.0)}, "lo <= hi"),
        ({"plane": np.zeros((1, 3))}, "plane"),
        ({"skip": np.zeros(2, np.int64)}, "skip"),
        ({"direction": np.zeros((2, 3))}, "same shape"),
        ({"ops": np.array([[99, 0, 0]], np.int32), "consts": np.zeros(1)}, "opcode"),
    ],
)
def test_core_subdivision_rejects_bad_input(change, match):
    from rdmesh.core import prove_boxes

    args = _prove_args()
    one = {k: (args[k][:1] if k in ("lo", "hi", "cell", "direction", "floor") else args[k])
           for k in args}  # fmt: skip
    one.update(change)
    with pytest.raises(ValueError, match=match):
        prove_boxes(**one)


# -- root isolation on segments -------------------------------------------------------------


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize(
    "text",
    [
        "x**2 + y**2 + z**2 - 1",
        "(x**2 + y**2 + z**2 + 1 - 0.1**2)**2 - 4*(x**2 + y**2)",
        "sin(3*x)*cos(3*y) + sin(3*y)*cos(3*z) + sin(3*z)*cos(3*x)",
        "min(sqrt(x**2+y**2+z**2)-1, sqrt((x-1.5)**2+(y-0.3)**2+(z-0.2)**2)-0.02)",
    ],
)
def test_core_isolation_finds_the_pieces_of_the_reference_bisection(text, seed):
    # Found and pending pieces are the leaves of one bisection tree, so the
    # core (depth first, over the cores) and the reference (level by level)
    # must give exactly the same ones, with the same rules' bounds.
    from rdmesh.sampling.isolate import isolate_roots

    expr = parse_expression(text)
    rng = np.random.default_rng(seed)
    a = rng.uniform(-1.6, 1.6, (400, 3))
    b = a + rng.normal(scale=0.7, size=(400, 3))
    # Segments tangent to the unit sphere at their midpoint, and a point segment.
    n = rng.normal(size=(20, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    t = np.cross(n, rng.normal(size=(20, 3)))
    t /= np.linalg.norm(t, axis=1)[:, None]
    a = np.concatenate([a, n - 0.3 * t, [[0.3, 0.2, 0.1]]])
    b = np.concatenate([b, n + 0.3 * t, [[0.3, 0.2, 0.1]]])
    # Whole segments, and two pieces of each (the middle fifth left out).
    m = len(a)
    pieces = (np.r_[np.arange(m), np.arange(m)], np.r_[np.zeros(m), np.full(m, 0.6)],
              np.r_[np.full(m, 0.4), np.ones(m)])  # fmt: skip
    for part in (None, pieces):
        got = isolate_roots(expr, a, b, 1e-7, part)
        with reference_rules():
            ref = reference.isolate_roots(expr, a, b, 1e-7, part)
        for field in ("segment", "lo", "hi", "count", "resolved", "pending_segment",
                      "pending_lo", "pending_hi", "boxes"):  # fmt: skip
            assert np.array_equal(getattr(got, field), getattr(ref, field)), field
        assert got.count.sum() > 0
    # The pieces hold the roots of the whole segments outside the middle fifth:
    # at least those bracketed wholly outside it, at most those bracketed
    # partly outside it.
    whole = isolate_roots(expr, a, b, 1e-7)
    out = np.bincount(whole.segment[(whole.hi <= 0.4) | (whole.lo >= 0.6)], minlength=m)
    part = np.bincount(whole.segment[(whole.lo <= 0.4) | (whole.hi >= 0.6)], minlength=m)
    both = whole.resolved & got.resolved
    assert np.all((out <= got.count)[both]) and np.all((got.count <= part)[both])
    assert (got.count < whole.count).any()  # roots in the middle were left out
    got = whole
    if text.startswith("x**2 + y**2"):
        assert not got.resolved[400:420].all()  # the tangent segments stay pending


def test_segment_pieces_cover_the_segments_in_the_boxes_without_overlap():
    from rdmesh.core import segment_pieces

    rng = np.random.default_rng(3)
    n, k = 300, 40
    a = rng.uniform(-1, 1, (n, 3))
    b = a + rng.normal(scale=0.6, size=(n, 3))
    b[:10, 2] = a[:10, 2]  # parallel to the z slabs
    lo = rng.uniform(-1, 0.8, (k, 3))
    hi = lo + rng.uniform(0.01, 0.5, (k, 3))
    first = np.r_[0, np.sort(rng.integers(0, k, 9)), k]  # 10 groups of boxes
    host = rng.integers(-1, 10, n)
    seg, t0, t1 = segment_pieces(a, b, host, first, lo, hi, 1e-9)
    assert np.all((t0 >= 0) & (t0 <= t1) & (t1 <= 1))
    # By segment, then t0, and a segment's pieces do not meet.
    assert np.all(np.diff(seg) >= 0)
    same = seg[1:] == seg[:-1]
    assert np.all(t1[:-1][same] < t0[1:][same])
    # A hostless segment is one whole piece.
    for i in np.flatnonzero(host < 0):
        assert np.array_equal(np.c_[t0, t1][seg == i], [[0.0, 1.0]])
    # Every point of a segment inside one of its host's boxes is in a piece,
    # and every piece's middle is within its slack of such a box.
    t = np.linspace(0, 1, 2001)
    for i in np.flatnonzero(host >= 0)[:120]:
        x = a[i] + t[:, None] * (b[i] - a[i])
        box = slice(first[host[i]], first[host[i] + 1])
        inside = np.all((x[:, None] >= lo[box]) & (x[:, None] <= hi[box]), axis=2).any(axis=1)
        mine = seg == i
        covered = ((t[:, None] >= t0[mine]) & (t[:, None] <= t1[mine])).any(axis=1)
        assert np.all(covered[inside])
        mid = a[i] + (0.5 * (t0[mine] + t1[mine]))[:, None] * (b[i] - a[i])
        near = np.all((mid[:, None] >= lo[box] - 1e-6) & (mid[:, None] <= hi[box] + 1e-6), axis=2)
        assert near.any(axis=1).all()


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"host": np.full(2, 5)}, "host ids"),
        ({"host": np.zeros(3, np.int64)}, "one per segment"),
        ({"first": np.array([0, 3])}, "rise from 0"),
        ({"a": np.full((2, 3), np.inf)}, "finite"),
        ({"slack": -1.0}, "slack"),
    ],
)
def test_segment_pieces_rejects_bad_input(change, match):
    from rdmesh.core import segment_pieces

    args = {"a": np.zeros((2, 3)), "b": np.ones((2, 3)), "host": np.array([0, -1]),
            "first": np.array([0, 1]), "lo": np.zeros((1, 3)), "hi": np.ones((1, 3)),
            "slack": 0.0}  # fmt: skip
    args.update(change)
    with pytest.raises(ValueError, match=match):
        segment_pieces(**args)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"a": np.full((1, 3), np.nan)}, "finite"),
        ({"b": np.zeros((2, 3))}, "same shape"),
        ({"min_length": 0.0}, "min_length"),
        ({"budget": 0}, "budget"),
        ({"ops": np.array([[1, 5, -1]], np.int32), "consts": np.zeros(1)}, "axis"),
        ({"t0": np.zeros(1)}, "together"),
        ({"t0": np.zeros(2), "t1": np.ones(2)}, "one per segment"),
        ({"t0": np.full(1, 0.5), "t1": np.full(1, 0.2)}, "t0 <= t1"),
        ({"t0": np.zeros(1), "t1": np.full(1, 1.5)}, "t1 <= 1"),
    ],
)
def test_core_isolation_rejects_bad_input(change, match):
    from rdmesh.core import isolate_segment_roots

    ops, consts = compile_program(parse_expression("x**2 + y**2 + z**2 - 1")._root)
    args = {"ops": ops, "consts": consts, "a": np.zeros((1, 3)), "b": np.ones((1, 3)),
            "min_length": 1e-9, "budget": 100}  # fmt: skip
    args.update(change)
    with pytest.raises(ValueError, match=match):
        isolate_segment_roots(**args)
