"""Interval enclosures: containment of sampled values and gradients, exact cases, domains.

Every test runs twice: on the library's evaluator (the core's, C++) and on the
numpy reference of the same rules (tests/interval_reference.py).
"""

from __future__ import annotations

import decimal
import math
import zlib
from fractions import Fraction

import interval_reference
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rdmesh.core import INTERVAL_OPS
from rdmesh.surfaces import SURFACES, intervals, pointwise
from rdmesh.surfaces.builtin import BUILTIN_EXPRESSIONS
from rdmesh.surfaces.expressions import FUNCTIONS, parse_expression
from rdmesh.surfaces.intervals import Enclosure, GradientEnclosure, interval, interval_gradient
from rdmesh.surfaces.ir import ALIASES, NARY, UNARY

#: Coordinates where functions of the grammar have kinks, poles, jumps or domain edges.
SPECIAL = np.array(
    [0.0, 1.0, -1.0, 0.5, -0.5, 2.0, -2.0, 3.0] + [k * math.pi / 2 for k in (-3, -2, -1, 1, 2, 3)]
)
HALF_WIDTHS = np.array([0.0, 1e-15, 1e-9, 1e-4, 0.01, 0.3, 1.0, 3.0])


@pytest.fixture(autouse=True, params=["core", "reference"])
def evaluator(request, monkeypatch):
    """Every test runs on both evaluators: the core's and the numpy reference."""
    if request.param == "reference":
        monkeypatch.setattr(intervals, "_bounds", interval_reference.bounds)
    return request.param


# -- the checker ------------------------------------------------------------------------


def random_boxes(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Boxes of mixed sizes (degenerate to wide), centred near special points or anywhere."""
    kind = rng.integers(0, 3, (n, 3))
    centre = np.select(
        [kind == 0, kind == 1],
        [
            rng.choice(SPECIAL, (n, 3)),
            rng.choice(SPECIAL, (n, 3)) + rng.choice([-1e-12, 1e-12, -1e-3, 1e-3], (n, 3)),
        ],
        rng.uniform(-3, 3, (n, 3)),
    )
    half = rng.choice(HALF_WIDTHS, (n, 3))
    # Boxes straddling a special point off-centre too.
    shift = half * rng.uniform(-1, 1, (n, 3))
    return centre - half + shift, centre + half + shift


def sample_points(rng: np.random.Generator, lo: np.ndarray, hi: np.ndarray, k: int = 6):
    """(n, m, 3) points in each box: corners, centre, random and special points."""
    n = len(lo)
    corners = np.array([[i >> 2 & 1, i >> 1 & 1, i & 1] for i in range(8)], dtype=float)
    pts = [lo[:, None] + corners[None] * (hi - lo)[:, None]]
    pts.append((0.5 * (lo + hi))[:, None])
    pts.append(lo[:, None] + rng.uniform(0, 1, (n, k, 3)) * (hi - lo)[:, None])
    centre = 0.5 * (lo + hi)
    for s in SPECIAL:  # each coordinate at s where the box holds s
        inside = (lo <= s) & (s <= hi)
        if inside.any():
            pts.append(np.where(inside, s, centre)[:, None])
    return np.clip(np.concatenate(pts, axis=1), lo[:, None], hi[:, None])


def exact_gradient(expr, points: np.ndarray) -> np.ndarray:
    """The forward-mode gradient at (N, 3) points, NaN/inf where it is not finite."""
    with np.errstate(all="ignore"):
        _, g = pointwise.dual(expr._root, (points[:, 0], points[:, 1], points[:, 2]))
    if g is None:
        return np.zeros_like(points)
    return np.array(np.broadcast_to(np.asarray(g, dtype=float), (3, len(points))).T)


def check(expr, lo, hi, rng, enc: GradientEnclosure | None = None) -> int:
    """Assert that the enclosure holds f and grad f at sampled points; return #checks.

    A point counts where f is defined there, i.e. where the degenerate box at
    the point is not flagged undefined (checked for consistency below).
    """
    if enc is None:
        enc = interval_gradient(expr, lo, hi)
    flo, fhi, glo, ghi, undef = enc
    n = len(lo)
    for a in (flo, fhi, glo, ghi):
        assert not np.isnan(a).any(), "NaN bound"
    assert (flo <= fhi).all() and (glo <= ghi).all()

    pts = sample_points(rng, lo, hi)
    m = pts.shape[1]
    flat = pts.reshape(-1, 3)
    at = interval(expr, flat, flat)
    defined = ~at.undefined.reshape(n, m)
    # A box flagged defined has only defined points.
    assert defined[~undef].all(), f"{expr}: box defined but a point in it is not"

    v = expr(flat).reshape(n, m)
    ok = defined & ~np.isnan(v)
    bad = ok & ((v < flo[:, None]) | (v > fhi[:, None]))
    if bad.any():
        i, j = np.argwhere(bad)[0]
        pytest.fail(
            f"{expr}: f{tuple(pts[i, j])} = {v[i, j]!r} outside [{flo[i]!r}, {fhi[i]!r}] "
            f"on box {lo[i].tolist()} .. {hi[i].tolist()}"
        )
    g = exact_gradient(expr, flat).reshape(n, m, 3)
    gok = defined[..., None] & np.isfinite(g)
    gbad = gok & ((g < glo[:, None]) | (g > ghi[:, None]))
    if gbad.any():
        i, j, k = np.argwhere(gbad)[0]
        pytest.fail(
            f"{expr}: df/d{'xyz'[k]}{tuple(pts[i, j])} = {g[i, j, k]!r} outside "
            f"[{glo[i, k]!r}, {ghi[i, k]!r}] on box {lo[i].tolist()} .. {hi[i].tolist()}"
        )

    # The mean-value form: never looser than the natural one, and it holds f too.
    # It does not retrace numpy's rounding, so numpy's value may fall an ulp
    # outside; the exact f(p) is in the point's own enclosure, which must meet it.
    mv = interval(expr, lo, hi, mean_value=True)
    assert (mv.lo >= flo).all() and (mv.hi <= fhi).all()
    assert (mv.undefined == undef).all()
    plo, phi = at.lo.reshape(n, m), at.hi.reshape(n, m)
    mbad = defined & ((phi < mv.lo[:, None]) | (plo > mv.hi[:, None]))
    if mbad.any():
        i, j = np.argwhere(mbad)[0]
        pytest.fail(
            f"{expr} (mean value): f{tuple(pts[i, j])} in [{plo[i, j]!r}, {phi[i, j]!r}] "
            f"outside [{mv.lo[i]!r}, {mv.hi[i]!r}] on box {lo[i].tolist()} .. {hi[i].tolist()}"
        )
    return int(ok.sum())


def test_checker_catches_a_wrong_enclosure():
    """The checker is not vacuous: a slightly narrowed enclosure or gradient fails it."""
    expr = parse_expression("sin(x) * y + z**2")
    rng = np.random.default_rng(1)
    lo, hi = random_boxes(rng, 50)
    enc = interval_gradient(expr, lo, hi)
    assert check(expr, lo, hi, np.random.default_rng(2), enc) > 500
    narrow = enc._replace(hi=enc.lo + 0.99 * (enc.hi - enc.lo))
    with pytest.raises(pytest.fail.Exception, match="outside"):
        check(expr, lo, hi, np.random.default_rng(2), narrow)
    gnarrow = enc._replace(glo=enc.glo + 0.01 * (enc.ghi - enc.glo))
    with pytest.raises(pytest.fail.Exception, match="df/d"):
        check(expr, lo, hi, np.random.default_rng(2), gnarrow)


# -- every function of the grammar --------------------------------------------------------


def _calls(name: str) -> list[str]:
    """Texts exercising a function on plain and composite arguments."""
    key = ALIASES.get(name, name)
    if key in UNARY:
        return [f"{name}(x)", f"{name}(2*x - y) * z", f"{name}(x*y + 0.5) + {name}(z)"]
    if key == "pow":
        return ["pow(x, y)", "pow(x, 3)", "pow(y, -2) + pow(z, 0.5)", "pow(x*x + 0.5, y - z)"]
    if NARY[key][1] == 2:
        return [f"{name}(y, x)", f"{name}(x - z, y*x)"]
    return [f"{name}(x, y)", f"{name}(x, y, z)", f"{name}(x*y, 1 - z, x + 0.25)"]


def test_every_function_has_a_rule_in_both_evaluators():
    names = {ALIASES.get(n, n) for n in FUNCTIONS}
    assert names <= set(INTERVAL_OPS)
    assert set(UNARY) - {"tan"} <= set(interval_reference.UNARY_RULES)


@pytest.mark.parametrize("name", FUNCTIONS)
def test_every_function_contains_samples(name):
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    for text in _calls(name):
        expr = parse_expression(text)
        lo, hi = random_boxes(rng, 400)
        assert check(expr, lo, hi, rng) > 300, text


OPERATORS = [
    "x + y - z",
    "x * y * z",
    "x / y",
    "(x + 1) / (y - z)",
    "x**2 - y**3 + z**-1",
    "x**-2 + y**4 - z**5",
    "x**0.5 + y**1.5 - z**-0.5",
    "x**y",
    "2**x - x**0",
    "-x + -(y*z)",
    "x**(4/2) + y**(1/3)",
    "1e999 * x",
    "x * 1e-300 * 1e-300",
    "exp(x*300) - exp(y*300)",
]


@pytest.mark.parametrize("text", OPERATORS)
def test_operators_contain_samples(text):
    rng = np.random.default_rng(zlib.crc32(text.encode()))
    expr = parse_expression(text)
    lo, hi = random_boxes(rng, 400)
    check(expr, lo, hi, rng)


# -- random expressions --------------------------------------------------------------------

_UNARY_NAMES = [n for n in FUNCTIONS if ALIASES.get(n, n) in UNARY]

_LEAVES = st.sampled_from(["x", "y", "z", "x", "y", "z", "1", "2", "0.5", "pi", "3", "0"])


def _extend(children):
    return st.one_of(
        st.builds(lambda f, a: f"{f}({a})", st.sampled_from(_UNARY_NAMES), children),
        st.builds(
            lambda a, op, b: f"({a}) {op} ({b})",
            children,
            st.sampled_from(["+", "-", "*", "/"]),
            children,
        ),
        st.builds(
            lambda a, p: f"({a})**{p}",
            children,
            st.sampled_from(["2", "3", "4", "-1", "-2", "0.5", "1.5", "(-1/3)", "0"]),
        ),
        st.builds(lambda a, b: f"({a})**({b})", children, children),
        st.builds(
            lambda f, args: f"{f}({', '.join(args)})",
            st.sampled_from(["min", "max", "hypot"]),
            st.lists(children, min_size=2, max_size=3),
        ),
        st.builds(
            lambda f, a, b: f"{f}({a}, {b})", st.sampled_from(["atan2", "pow"]), children, children
        ),
    )


EXPRESSION_TEXTS = st.recursive(_LEAVES, _extend, max_leaves=7)


@settings(
    max_examples=400,
    derandomize=True,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(text=EXPRESSION_TEXTS, seed=st.integers(0, 2**32 - 1))
def test_random_expressions_contain_samples(text, seed):
    rng = np.random.default_rng(seed)
    expr = parse_expression(text)
    lo, hi = random_boxes(rng, 40)
    check(expr, lo, hi, rng)


# -- exact cases -----------------------------------------------------------------------------


def one(text: str, lo, hi) -> GradientEnclosure:
    """The enclosure on a single box, as Python floats."""
    r = interval_gradient(text, np.array([lo], float), np.array([hi], float))
    return GradientEnclosure(
        float(r.lo[0]), float(r.hi[0]), r.glo[0], r.ghi[0], bool(r.undefined[0])
    )


def tight(lo: float, hi: float, want_lo: float, want_hi: float, ulps: float = 4) -> None:
    """[lo, hi] holds [want_lo, want_hi] and exceeds it by at most a few ulps."""
    assert lo <= want_lo and hi >= want_hi, (lo, hi, want_lo, want_hi)
    slack = ulps * np.finfo(float).eps * max(abs(want_lo), abs(want_hi), 1e-300)
    assert want_lo - lo <= slack and hi - want_hi <= slack, (lo, hi, want_lo, want_hi)


X = ([-1.0, 0.0, 0.0], [2.0, 0.0, 0.0])  # x in [-1, 2]


def test_even_power_is_the_true_square():
    r = one("x**2", *X)
    tight(r.lo, r.hi, 0.0, 4.0)
    assert r.lo == 0.0  # x**2 >= 0 exactly, not widened below
    assert not r.undefined
    tight(r.glo[0], r.ghi[0], -2.0, 4.0)
    assert (r.glo[1:] == 0).all() and (r.ghi[1:] == 0).all()


def test_product_of_a_variable_with_itself_is_the_general_product():
    r = one("x*x", *X)
    tight(r.lo, r.hi, -2.0, 4.0)


def test_odd_and_negative_powers():
    r = one("x**3", *X)
    tight(r.lo, r.hi, -1.0, 8.0, ulps=16)
    r = one("x**4", *X)
    tight(r.lo, r.hi, 0.0, 16.0, ulps=16)
    r = one("x**-2", [0.5, 0, 0], [2.0, 0, 0])
    tight(r.lo, r.hi, 0.25, 4.0, ulps=16)
    assert not r.undefined
    r = one("x**-1", [-1, 0, 0], [1, 0, 0])
    assert (r.lo, r.hi, r.undefined) == (-np.inf, np.inf, True)
    r = one("x**-2", [0.0, 0, 0], [2.0, 0, 0])  # pole at 0: [1/4, inf], undefined
    tight(r.lo, 0.25, 0.25, 0.25, ulps=16)
    assert r.hi == np.inf and r.undefined


def test_real_powers():
    r = one("x**0.5", [0.0, 0, 0], [4.0, 0, 0])
    tight(r.lo, r.hi, 0.0, 2.0, ulps=16)
    assert not r.undefined and r.ghi[0] == np.inf
    r = one("x**1.5", *X)  # negative base: undefined, bounds over [0, 2]
    assert r.undefined
    tight(r.lo, r.hi, 0.0, 2.0**1.5, ulps=16)
    r = one("x**y", [0.5, 1, 0], [2.0, 2, 0])
    tight(r.lo, r.hi, 0.25, 4.0, ulps=40)
    assert not r.undefined
    assert one("x**y", [0.0, 1, 0], [2.0, 2, 0]).undefined


def test_abs_and_its_gradient_hull():
    r = one("abs(x)", *X)
    tight(r.lo, r.hi, 0.0, 2.0)
    assert r.lo == 0.0
    assert (r.glo[0], r.ghi[0]) == (-1.0, 1.0)  # both branches, not sign(0) = 0
    r = one("abs(x)", [0.5, 0, 0], [2.0, 0, 0])
    assert (r.glo[0], r.ghi[0]) == (1.0, 1.0)


def test_sqrt():
    r = one("sqrt(x)", [0.0, 0, 0], [4.0, 0, 0])
    tight(r.lo, r.hi, 0.0, 2.0)
    assert not r.undefined
    tight(r.glo[0], 0.25, 0.25, 0.25)  # 0.5/sqrt(u) over [0, 4]: [1/4, inf]
    assert r.ghi[0] == np.inf
    assert one("sqrt(x)", [-1e-300, 0, 0], [4.0, 0, 0]).undefined


def test_division_by_an_interval_holding_zero():
    r = one("1/x", [-1.0, 0, 0], [1.0, 0, 0])
    assert (r.lo, r.hi) == (-np.inf, np.inf)
    assert r.undefined
    r = one("1/x", [0.0, 0, 0], [2.0, 0, 0])  # extended division: [1/2, inf]
    tight(r.lo, 0.5, 0.5, 0.5)
    assert r.hi == np.inf and r.undefined
    r = one("1/x", [1.0, 0, 0], [2.0, 0, 0])
    tight(r.lo, r.hi, 0.5, 1.0)
    assert not r.undefined
    tight(r.glo[0], r.ghi[0], -1.0, -0.25)


def test_sin_cos_tan():
    r = one("sin(x)", [0.0, 0, 0], [math.pi, 0, 0])
    tight(r.lo, r.hi, 0.0, 1.0, ulps=16)
    assert r.lo <= 0.0 and r.hi == 1.0
    tight(r.glo[0], r.ghi[0], -1.0, 1.0, ulps=16)
    r = one("cos(x)", [-0.5, 0, 0], [4.0, 0, 0])
    tight(r.lo, r.hi, -1.0, 1.0)
    r = one("sin(x)", [0.1, 0, 0], [0.2, 0, 0])
    tight(r.lo, r.hi, math.sin(0.1), math.sin(0.2), ulps=40)
    r = one("sin(x)", [-1e9, 0, 0], [1e9, 0, 0])
    assert (r.lo, r.hi) == (-1.0, 1.0)
    r = one("tan(x)", [1.0, 0, 0], [2.0, 0, 0])  # pole at pi/2
    assert (r.lo, r.hi, r.undefined) == (-np.inf, np.inf, True)
    r = one("tan(x)", [-1.0, 0, 0], [1.0, 0, 0])
    tight(r.lo, r.hi, math.tan(-1.0), math.tan(1.0), ulps=40)
    assert not r.undefined


def test_exp_and_log():
    r = one("exp(x)", [0.0, 0, 0], [1.0, 0, 0])
    tight(r.lo, r.hi, 1.0, math.e, ulps=40)
    r = one("log(x)", [-1.0, 0, 0], [1.0, 0, 0])
    assert r.undefined and r.lo == -np.inf
    tight(-1.0, r.hi, -1.0, 0.0)  # log over the defined part (0, 1]: hi ~ 0
    r = one("log(x)", [1.0, 0, 0], [math.e, 0, 0])
    tight(r.lo, r.hi, 0.0, 1.0, ulps=40)
    assert not r.undefined
    assert one("log(x)", [0.0, 0, 0], [1.0, 0, 0]).undefined
    r = one("log(x)", [-2.0, 0, 0], [-1.0, 0, 0])  # no point of the box is defined
    assert (r.lo, r.hi, r.undefined) == (-np.inf, np.inf, True)


def test_min_max():
    box = ([-1.0, 0.5, 3.0], [2.0, 1.0, 4.0])
    r = one("min(x, y)", *box)
    assert (r.lo, r.hi) == (-1.0, 1.0)
    # Both branches possible: the hull of (1, 0, 0) and (0, 1, 0).
    assert r.glo.tolist() == [0, 0, 0] and r.ghi.tolist() == [1, 1, 0]
    r = one("max(x, y, z)", *box)
    assert (r.lo, r.hi) == (3.0, 4.0)
    assert r.glo.tolist() == [0, 0, 1] and r.ghi.tolist() == [0, 0, 1]  # z alone
    r = one("min(y, z)", *box)  # y < z throughout: only y's gradient
    assert r.glo.tolist() == [0, 1, 0] and r.ghi.tolist() == [0, 1, 0]


def test_gradient_of_sum_of_squares():
    r = one("x**2 + y**2", [-1.0, 2.0, 5.0], [3.0, 4.0, 6.0])
    tight(r.lo, r.hi, 4.0, 25.0)
    tight(r.glo[0], r.ghi[0], -2.0, 6.0)
    tight(r.glo[1], r.ghi[1], 4.0, 8.0)
    assert r.glo[2] == 0 and r.ghi[2] == 0


def test_other_functions():
    tight(*one("atan(x)", *X)[:2], math.atan(-1), math.atan(2), ulps=40)
    tight(*one("cosh(x)", *X)[:2], 1.0, math.cosh(2), ulps=40)
    assert one("cosh(x)", *X).lo == 1.0
    tight(*one("tanh(x)", *X)[:2], math.tanh(-1), math.tanh(2), ulps=40)
    tight(*one("cbrt(x)", [-8.0, 0, 0], [27.0, 0, 0])[:2], -2.0, 3.0, ulps=40)
    tight(*one("hypot(x, y)", [3.0, 4.0, 0], [3.0, 4.0, 0])[:2], 5.0, 5.0, ulps=40)
    tight(*one("hypot(x, y)", [-1.0, -1.0, 0], [1.0, 1.0, 0])[:2], 0.0, math.sqrt(2), 40)
    r = one("atan2(y, x)", [1.0, 1.0, 0], [2.0, 2.0, 0])
    tight(r.lo, r.hi, math.atan2(1, 2), math.atan2(2, 1), ulps=40)
    r = one("atan2(y, x)", [-2.0, -1.0, 0], [-1.0, 1.0, 0])  # across the branch cut
    assert r.lo <= -math.pi and r.hi >= math.pi and not r.undefined
    assert np.isinf(r.glo[:2]).all() and np.isinf(r.ghi[:2]).all()
    assert one("atan2(y, x)", [-1.0, -1.0, 0], [1.0, 1.0, 0]).undefined  # origin
    r = one("floor(x) + ceil(y) + sign(z)", [0.5, 0.5, 0.5], [0.7, 0.7, 0.7])
    assert (r.lo, r.hi) == (2.0, 2.0) and (r.glo == 0).all() and (r.ghi == 0).all()
    r = one("floor(x)", [0.5, 0, 0], [1.5, 0, 0])  # a jump: unbounded slope
    assert (r.lo, r.hi) == (0.0, 1.0) and r.glo[0] == 0 and r.ghi[0] == np.inf


DOMAINS = [
    # (text, box for x, undefined?)
    ("sqrt(x)", (0.0, 1.0), False),
    ("sqrt(x)", (-0.1, 1.0), True),
    ("log(x)", (1e-300, 1.0), False),
    ("log(x)", (0.0, 1.0), True),
    ("ln(x)", (-1.0, 1.0), True),
    ("log2(x)", (-1.0, 1.0), True),
    ("log10(x)", (0.5, 1.0), False),
    ("log1p(x)", (-0.5, 1.0), False),
    ("log1p(x)", (-1.0, 1.0), True),
    ("asin(x)", (-1.0, 1.0), False),
    ("asin(x)", (-1.0, 1.0 + 1e-15), True),
    ("acos(x)", (-1.5, 0.0), True),
    ("acosh(x)", (1.0, 2.0), False),
    ("acosh(x)", (0.5, 2.0), True),
    ("atanh(x)", (-0.5, 0.5), False),
    ("atanh(x)", (-1.0, 0.0), True),
    ("x**0.5", (-1.0, 1.0), True),
    ("x**-1.5", (0.0, 1.0), True),
    ("x**-1.5", (0.5, 1.0), False),
    ("x**-3", (-1.0, 0.0), True),
    ("x**3", (-1.0, 0.0), False),
    ("1/x", (0.5, 1.0), False),
    ("1/(x - 1)", (0.5, 1.0), True),
    ("tan(x)", (-1.5, 1.5), False),
    ("tan(x)", (1.5, 1.6), True),
    ("cos(x)**0.5", (-1.0, 1.0), False),
    ("sqrt(x - x)", (-1.0, 1.0), True),  # conservative: x - x is [-2, 2] on the box
    ("sqrt(x*x)", (-1.0, 1.0), True),  # x*x is the general product [-1, 1]
    ("sqrt(x**2)", (-1.0, 1.0), False),
    ("1e999 + x", (0.0, 1.0), True),
]


@pytest.mark.parametrize(("text", "box", "undefined"), DOMAINS)
def test_domains(text, box, undefined):
    r = one(text, [box[0], 0.25, 0.5], [box[1], 0.25, 0.5])
    assert r.undefined == undefined
    assert not math.isnan(r.lo) and not math.isnan(r.hi)


def test_point_boxes_inside_domains_are_defined():
    """Well-defined expressions are not flagged anywhere (the flag is not vacuous)."""
    rng = np.random.default_rng(5)
    lo, hi = random_boxes(rng, 500)
    for text in [
        "x**2 + y**2 + z**2 - 1",
        "sqrt(x**2 + 1) + log(1 + y**2) + asin(sin(z)) + exp(-x) * cosh(y)",
        "hypot(x, y, z) - min(x, y) + max(y, z) + abs(x) + atan(y) * tanh(z)",
        "x**3 - 2**y + pow(1 + z**2, 0.5) + floor(x) + cbrt(y)",
    ]:
        assert not interval(text, lo, hi).undefined.any(), text


# -- the mean-value form ----------------------------------------------------------------------


def test_mean_value_form_is_tighter_on_small_boxes():
    # f = z up to cancellation, which the natural form does not see.
    expr = parse_expression("(x - y)*(x + y) - x**2 + y**2 + z*exp(x - x)")
    rng = np.random.default_rng(3)
    centre = rng.uniform(-2, 2, (300, 3))
    for h in (1e-2, 1e-3):
        lo, hi = centre - h, centre + h
        nat = interval(expr, lo, hi)
        mv = expr.interval(lo, hi, mean_value=True)
        assert (mv.lo >= nat.lo).all() and (mv.hi <= nat.hi).all()
        assert np.median((mv.hi - mv.lo) / (nat.hi - nat.lo)) < 0.3
        check(expr, lo, hi, rng)
    # On small boxes its width is about 2h * sum |grad f| (here 2h).
    h = 1e-6
    mv = interval(expr, centre - h, centre + h, mean_value=True)
    assert np.all(mv.hi - mv.lo <= 2 * h * 1.01)


# -- API -------------------------------------------------------------------------------------


def test_methods_and_functions_agree():
    expr = parse_expression("x*y - z")
    lo, hi = np.zeros((4, 3)), np.ones((4, 3))
    a, b = expr.interval(lo, hi), interval("x*y - z", lo, hi)
    assert isinstance(a, Enclosure)
    assert all(np.array_equal(u, v) for u, v in zip(a, b, strict=True))
    c = expr.interval_gradient(lo, hi)
    assert isinstance(c, GradientEnclosure)
    assert c.glo.shape == (4, 3) and c.lo.shape == (4,) and c.undefined.dtype == bool
    flo, fhi, undefined = expr.interval([0, 0, 0], [1, 1, 1])  # one box as (3,)
    assert flo.shape == (1,)
    tight(float(flo[0]), float(fhi[0]), -1.0, 1.0)


def test_constant_expression_broadcasts():
    r = interval_gradient("pi/3 + 1", np.zeros((3, 3)), np.ones((3, 3)))
    exact = Fraction(math.pi) / 3 + 1
    assert r.lo.shape == (3,)
    assert all(Fraction(u) < exact < Fraction(v) for u, v in zip(r.lo, r.hi, strict=True))
    assert (r.glo == 0).all() and (r.ghi == 0).all()


def test_infinite_boxes():
    r = one("x**2 + 1", [-np.inf, 0, 0], [np.inf, 0, 0])
    assert (r.lo, r.hi) == (1.0, np.inf)
    r = one("exp(x) - x", [-np.inf, 0, 0], [0.0, 0, 0])
    assert r.hi == np.inf and not math.isnan(r.lo)


BAD_BOXES = [
    (np.zeros((2, 2)), np.zeros((2, 2)), "shape"),
    (np.zeros((2, 3)), np.zeros((3, 3)), "shape"),
    (np.full((1, 3), np.nan), np.zeros((1, 3)), "NaN"),
    (np.ones((1, 3)), np.zeros((1, 3)), "lo <= hi"),
    (np.full((1, 3), np.inf), np.full((1, 3), np.inf), "below"),
]


@pytest.mark.parametrize(("lo", "hi", "match"), BAD_BOXES)
def test_bad_boxes(lo, hi, match):
    with pytest.raises(ValueError, match=match):
        interval("x", lo, hi)


# -- built-in surfaces --------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(SURFACES))
def test_builtin_expressions_match_the_numpy_functions(name):
    surface = SURFACES[name].make()
    expr = parse_expression(BUILTIN_EXPRESSIONS[name])
    rng = np.random.default_rng(11)
    c, r = surface.bounding_sphere
    p = c + r * rng.uniform(-1, 1, (5000, 3))
    f, fe = surface.f(p), expr(p)
    assert np.all(np.abs(fe - f) <= 1e-12 * np.maximum(1.0, np.abs(f)))
    g, ge = surface.gradient(p), expr.gradient(p)
    assert np.all(np.abs(ge - g) <= 1e-12 * np.maximum(1.0, np.abs(g)))
    # And their enclosures hold the numpy values, on boxes across the bounding box.
    lo = c + r * rng.uniform(-1, 1, (300, 3))
    hi = lo + rng.choice([0.0, 1e-6, 0.01, 0.3], (300, 1))
    assert check(expr, lo, hi, rng) > 1000
    enc = expr.interval(lo, hi)
    assert not enc.undefined.any()


# -- rounding against exact arithmetic ------------------------------------------------------------


def _point_boxes(rng, n=300):
    """Values of all magnitudes, including subnormal and huge ones."""
    v = rng.uniform(0.5, 1, (n, 3)) * 2.0 ** rng.integers(-1070, 1000, (n, 3))
    v[: n // 2] = rng.uniform(-3, 3, (n // 2, 3))
    return v * rng.choice([-1.0, 1.0], (n, 3))


@pytest.mark.parametrize(
    ("text", "exact"),
    [
        ("x + y", lambda x, y: x + y),
        ("x - y", lambda x, y: x - y),
        ("x * y", lambda x, y: x * y),
        ("x / y", lambda x, y: x / y),
        ("x**2", lambda x, y: x * x),
        ("x**-1", lambda x, y: 1 / x),
        ("x**3 - y", lambda x, y: x**3 - y),
    ],
)
def test_outward_rounding_of_exact_operations(text, exact):
    """On point boxes the bounds hold the exact rational result (found with Fraction)."""
    p = _point_boxes(np.random.default_rng(8))
    r = interval(text, p, p)
    for (x, y, _), lo, hi in zip(p.tolist(), r.lo, r.hi, strict=True):
        want = exact(Fraction(x), Fraction(y))
        assert (lo == -np.inf or Fraction(lo) <= want) and (hi == np.inf or want <= Fraction(hi))


def test_outward_rounding_of_sqrt():
    p = np.abs(_point_boxes(np.random.default_rng(9)))
    r = interval("sqrt(x)", p, p)
    for x, lo, hi in zip(p[:, 0].tolist(), r.lo, r.hi, strict=True):
        assert Fraction(lo) ** 2 <= Fraction(x) <= Fraction(hi) ** 2


_D = decimal.Context(prec=80)
_PI = decimal.Decimal(
    "3.14159265358979323846264338327950288419716939937510582097494459230781640628620899863"
)


def _dsin(x: decimal.Decimal) -> decimal.Decimal:
    """sin by its Taylor series after reduction by 2*pi, 80 digits."""
    x = _D.subtract(x, _D.multiply(2 * _PI, _D.to_integral_value(_D.divide(x, 2 * _PI))))
    term, total, k = x, x, 1
    while abs(term) > decimal.Decimal("1e-70"):
        term = _D.divide(_D.multiply(-term, _D.multiply(x, x)), (2 * k) * (2 * k + 1))
        total, k = _D.add(total, term), k + 1
    return total


_DECIMAL = {
    "exp": lambda d: _D.exp(d),
    "expm1": lambda d: _D.subtract(_D.exp(d), 1),
    "log": lambda d: _D.ln(d),
    "log1p": lambda d: _D.ln(_D.add(1, d)),
    "log2": lambda d: _D.divide(_D.ln(d), _D.ln(2)),
    "log10": lambda d: _D.log10(d),
    "sinh": lambda d: _D.divide(_D.subtract(_D.exp(d), _D.exp(-d)), 2),
    "cosh": lambda d: _D.divide(_D.add(_D.exp(d), _D.exp(-d)), 2),
    "tanh": lambda d: _D.divide(_D.subtract(_D.exp(2 * d), 1), _D.add(_D.exp(2 * d), 1)),
    "sin": _dsin,
    "cos": lambda d: _dsin(_D.add(d, _PI / 2)),
    "sqrt": lambda d: _D.sqrt(d),
    "cbrt": lambda d: (1 if d >= 0 else -1) * _D.power(abs(d), _D.divide(1, 3)),
}


@pytest.mark.parametrize("name", sorted(_DECIMAL))
def test_libm_results_hold_the_exact_value(name):
    """Bounds of functions numpy does not round correctly hold the 80-digit value."""
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    x = np.concatenate([rng.uniform(-30, 30, 300), rng.uniform(-1, 1, 100) * 1e-8, [0.0, 1.0]])
    if name in ("log", "log2", "log10", "sqrt"):
        x = np.abs(x) + 1e-300
    if name == "log1p":
        x = np.maximum(x, -0.999)
    p = np.column_stack([x, x, x])
    r = interval(f"{name}(x)", p, p)
    for xi, lo, hi in zip(x.tolist(), r.lo, r.hi, strict=True):
        want = _DECIMAL[name](decimal.Decimal(xi))
        assert decimal.Decimal(lo) <= want <= decimal.Decimal(hi), (name, xi, lo, hi)


_DECIMAL_INVERSE = {
    # name: (inverse, increasing, sampling range)
    "asin": (_DECIMAL["sin"], True, (-0.999, 0.999)),
    "acos": (_DECIMAL["cos"], False, (-0.999, 0.999)),
    "atan": (lambda d: _D.divide(_DECIMAL["sin"](d), _DECIMAL["cos"](d)), True, (-1e6, 1e6)),
    "asinh": (_DECIMAL["sinh"], True, (-1e6, 1e6)),
    "acosh": (_DECIMAL["cosh"], True, (1.001, 1e6)),
    "atanh": (_DECIMAL["tanh"], True, (-0.999, 0.999)),
}


@pytest.mark.parametrize("name", sorted(_DECIMAL_INVERSE))
def test_inverse_functions_hold_the_exact_value(name):
    """g(lo) <= x <= g(hi) for the inverse g of f (80 digits), so f(x) is in [lo, hi]."""
    inverse, increasing, (a, b) = _DECIMAL_INVERSE[name]
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    x = np.concatenate([rng.uniform(a, b, 200), rng.uniform(a, min(b, a + 2), 100)])
    p = np.column_stack([x, x, x])
    r = interval(f"{name}(x)", p, p)
    for xi, lo, hi in zip(x.tolist(), r.lo, r.hi, strict=True):
        g_lo, g_hi = inverse(decimal.Decimal(lo)), inverse(decimal.Decimal(hi))
        if not increasing:
            g_lo, g_hi = g_hi, g_lo
        assert g_lo <= decimal.Decimal(xi) <= g_hi, (name, xi, lo, hi)


def test_two_argument_functions_hold_the_exact_value():
    rng = np.random.default_rng(12)
    x, y = rng.uniform(0.01, 30, 300), rng.uniform(-30, 30, 300)
    p = np.column_stack([x, y, y])
    for text, exact in [
        ("x**y", lambda u, v: _D.exp(_D.multiply(v, _D.ln(u)))),
        ("pow(x, 0.3)", lambda u, v: _D.exp(_D.multiply(decimal.Decimal(0.3), _D.ln(u)))),
        ("hypot(x, y)", lambda u, v: _D.sqrt(_D.add(u * u, v * v))),
        ("tan(y/10)", lambda u, v: _D.divide(_DECIMAL["sin"](v / 10), _DECIMAL["cos"](v / 10))),
    ]:
        r = interval(text, p, p)
        for u, v, lo, hi in zip(x.tolist(), y.tolist(), r.lo, r.hi, strict=True):
            want = exact(decimal.Decimal(u), decimal.Decimal(v))
            assert decimal.Decimal(lo) <= want <= decimal.Decimal(hi), (text, u, v, lo, hi)
