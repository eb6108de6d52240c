"""Expressions: safe parsing, vectorised values, exact gradients, meshing."""

from __future__ import annotations

import math

import numpy as np
import pytest
import rdmesh
from child import run_python
from rdmesh import ImplicitSurface, RdmeshError
from rdmesh.surfaces import pointwise
from rdmesh.surfaces.expressions import (
    FUNCTIONS,
    MAX_DEPTH,
    MAX_LENGTH,
    ExpressionError,
    parse_expression,
)

# -- a scalar reference: Python's math module, one point at a time ---------------


def _cbrt(u):
    return math.copysign(abs(u) ** (1.0 / 3.0), u)


def _sign(u):
    return float((u > 0) - (u < 0))


MATH = {
    "__builtins__": {},
    "abs": abs,
    "min": min,
    "max": max,
    "pow": math.pow,
    "pi": math.pi,
    "e": math.e,
    "tau": math.tau,
    "cbrt": _cbrt,
    "sign": _sign,
    "fabs": math.fabs,
    "ln": math.log,
    "hypot": math.hypot,
    "atan2": math.atan2,
    "arcsin": math.asin,
    "arccos": math.acos,
    "arctan": math.atan,
    "arcsinh": math.asinh,
    "arccosh": math.acosh,
    "arctanh": math.atanh,
    "arctan2": math.atan2,
}
_SAME_NAME = ["sin", "cos", "tan", "asin", "acos", "atan", "sinh", "cosh", "tanh", "asinh"]
_SAME_NAME += ["acosh", "atanh", "exp", "expm1", "log", "log1p", "log2", "log10", "sqrt"]
_SAME_NAME += ["floor", "ceil"]
MATH.update({name: getattr(math, name) for name in _SAME_NAME})


def scalar(text: str, points: np.ndarray) -> np.ndarray:
    """The test's reference: eval with only math functions, point by point."""
    code = compile(text, "<test>", "eval")
    return np.array([eval(code, MATH, {"x": x, "y": y, "z": z}) for x, y, z in points.tolist()])


#: Expressions defined (and smooth, except at measure-zero kinks) on [-1, 1]^3.
EXPRESSIONS = [
    "x**2 + y**2 + z**2 - 1",
    "sin(x)*cos(y) + sin(y)*cos(z) + sin(z)*cos(x)",
    "exp(-x*x) - 2*y/(1 + z**2) + sqrt(x*x + 1)",
    "abs(x) - min(y, z, 0.5) + max(x, y) + fabs(z)",
    "hypot(x, y, z) - atan2(y, x + 2) + arctan2(z, 3) + tan(z/3)",
    "log(1 + x**2) + log2(2 + y*y) + log10(3 + z*z) + log1p(x*x) + expm1(y/4) + ln(2 + z)",
    "sinh(x/2) + cosh(y/2) + tanh(z) + asinh(x) + atan(y) + acosh(2 + z*z) + atanh(x/4)",
    "asin(y/4) + acos(z/4) + arcsin(x/2) + arccos(y/2) + arctan(z) + arcsinh(y) + arccosh(3)",
    "pow(x*x + 1, y) - (x*x + 1)**-z + pi*e - tau/2 + 2**x",
    "x - y - z + 2*x/3/(y*y + 1) - -y + +z - (x - (y - z))",
    "cbrt(x) + sign(y) + floor(2*z) + ceil(x) + 3 * 1e-3 / .5",
    "(x**2 + y**2 + z**2 + 1 - 0.16)**2 - 4*(x**2 + y**2)",
    "x**3 - 3*x*y**2 + y**-2 * 0 + z**0.5 * 0 + 7",
    "min(x, y) * max(y, z) + arctanh(z/2)",
    # A long sum: chains of + - and * / are flattened, so this is not "deep".
    " + ".join(f"{(k % 7) - 3}*x**{k % 5}*y**{k % 3}*z" for k in range(400)),
]


@pytest.fixture(scope="module")
def points() -> np.ndarray:
    p = np.random.default_rng(7).uniform(-1.0, 1.0, size=(200, 3))
    p[:, 2] = np.abs(p[:, 2]) + 1e-3  # z > 0 for z**0.5
    return p


@pytest.mark.parametrize("text", EXPRESSIONS, ids=range(len(EXPRESSIONS)))
def test_values_equal_python_math(text, points):
    expr = parse_expression(text)
    got = expr(points)
    assert got.shape == (len(points),) and got.dtype == np.float64
    np.testing.assert_allclose(got, scalar(text, points), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("text", EXPRESSIONS, ids=range(len(EXPRESSIONS)))
def test_gradient_matches_finite_differences(text, points):
    expr = parse_expression(text)
    g = expr.gradient(points)
    assert g.shape == (len(points), 3)
    h = 1e-6
    fd = np.column_stack(
        [(expr(points + h * e) - expr(points - h * e)) / (2 * h) for e in np.eye(3)]
    )
    np.testing.assert_allclose(g, fd, rtol=1e-5, atol=1e-5)


def test_exact_gradients_of_simple_expressions(points):
    np.testing.assert_allclose(
        parse_expression("x**2 + y**2 + z**2 - 1").gradient(points), 2 * points, rtol=1e-15
    )
    x, y = points[:, 0], points[:, 1]
    g = parse_expression("min(x, y)").gradient(points)
    np.testing.assert_array_equal(g[:, 0], (x <= y).astype(float))
    np.testing.assert_array_equal(g[:, 1], (x > y).astype(float))
    g = parse_expression("max(x, y, 0.25)").gradient(points)
    np.testing.assert_array_equal(g[:, 0], ((x >= y) & (x >= 0.25)).astype(float))


def test_kinks_use_the_branch_and_non_finite_derivatives_fall_back():
    origin = np.zeros((1, 3))
    # abs: derivative 0 at 0 (a subgradient); min: the first argument on ties.
    np.testing.assert_array_equal(parse_expression("abs(x)").gradient(origin), [[0, 0, 0]])
    np.testing.assert_array_equal(parse_expression("min(x, y)").gradient(origin), [[1, 0, 0]])
    # d sqrt(u) = du / (2 sqrt u) is 0/0 at the origin: central differences instead.
    r = parse_expression("sqrt(x**2 + y**2 + z**2) - 1")
    p = np.array([[0.0, 0.0, 0.0], [0.3, -0.4, 1.2]])
    g = r.gradient(p)
    assert np.all(np.isfinite(g))
    np.testing.assert_allclose(g[0], 0.0, atol=1e-9)
    np.testing.assert_allclose(g[1], p[1] / np.linalg.norm(p[1]), rtol=1e-12)


def test_constant_expressions_broadcast():
    e = parse_expression("2 * pi")
    p = np.ones((4, 3))
    np.testing.assert_array_equal(e(p), np.full(4, 2 * math.pi))
    np.testing.assert_array_equal(e.gradient(p), np.zeros((4, 3)))
    assert e.variables == frozenset()
    assert parse_expression("x*z + 1").variables == frozenset({"x", "z"})


def test_ieee_arithmetic_no_exceptions_no_hangs():
    p = np.zeros((3, 3))
    assert np.all(parse_expression("1/0 + x")(p) == np.inf)
    assert np.all(np.isnan(parse_expression("sqrt(-1 - x)")(p)))
    # float64, not Python integers: exact integer arithmetic would give 0 here.
    assert np.all(np.isnan(parse_expression("2**100000 - 2**100000 + x")(p)))  # inf - inf
    # ... and would never finish 9**9**9**9.  In a child process, so that a
    # hang fails the test (at a generous timeout) instead of stalling the run.
    code = (
        f"import numpy as np; from {parse_expression.__module__} import parse_expression; "
        "print(parse_expression('9**9**9**9')(np.zeros((3, 3))).tolist())"
    )
    out = run_python(code, timeout=600)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[inf, inf, inf]"


def test_line_breaks_and_blanks_are_spaces():
    e = parse_expression("  x**2 +\n  y**2\t- 1\r\n")
    p = np.array([[1.0, 2.0, 3.0]])
    assert e(p)[0] == 4.0
    assert e.text == "x**2 +   y**2 - 1"


def test_every_listed_function_is_accepted():
    p = np.array([[0.1, 0.2, 0.3]])
    for name in FUNCTIONS:
        args = "x, y" if name in ("min", "max", "hypot", "atan2", "arctan2", "pow") else "x"
        if name in ("acosh", "arccosh"):
            args = "x + 2"
        assert np.isfinite(parse_expression(f"{name}({args})")(p)).all(), name


# -- refused: each construct by name ------------------------------------------------------

REFUSED = [
    ("os", r"unknown name 'os'"),
    ("os.system('ls')", r"attribute access is not allowed"),
    ("x.real", r"attribute access is not allowed"),
    ("(1).__class__", r"attribute access is not allowed"),
    ("__import__('os')", r"unknown function '__import__'"),
    ("eval('1')", r"unknown function 'eval'"),
    ("open('/etc/passwd')", r"unknown function 'open'"),
    ("exec", r"unknown name 'exec'"),
    ("(x)(y)", r"unknown function 'x'"),
    ("sin(x)(y)", r"only the named functions can be called"),
    ("sin", r"'sin' is a function"),
    ("sin(x, y)", r"sin\(\) takes 1 argument, got 2"),
    ("min(x)", r"min\(\) takes at least 2 arguments, got 1"),
    ("atan2(x, y, z)", r"atan2\(\) takes 2 arguments, got 3"),
    ("sin(x=1)", r"keyword arguments are not allowed"),
    ("sin(*x)", r"starred arguments are not allowed"),
    ("x[0]", r"indexing and slicing are not allowed"),
    ("x < 1", r"comparisons are not allowed"),
    ("x and y", r"'and' and 'or' are not allowed"),
    ("not x", r"operator 'not' is not allowed"),
    ("x if y else z", r"conditional expressions are not allowed"),
    ("lambda: 1", r"lambda is not allowed"),
    ("(y := 1)", r"assignment \(:=\) is not allowed"),
    ("[x for x in y]", r"comprehensions are not allowed"),
    ("(x, y)", r"tuples are not allowed"),
    ("'abc'", r"strings are not allowed"),
    ("f'{x}'", r"f-strings are not allowed"),
    ("1j", r"complex numbers are not allowed"),
    ("True", r"True and False are not allowed"),
    ("None", r"None is not allowed"),
    ("x ^ 2", r"operator '\^' is not allowed; use \*\* for powers"),
    ("x % 2", r"operator '%' is not allowed"),
    ("x // 2", r"operator '//' is not allowed"),
    ("x +* 2", r"syntax error: .*\(column 4\)"),
    ("x**2 +", r"syntax error: .* at the end"),
    ("import os", r"syntax error"),
    ("x = 1", r"syntax error"),
    ("x; y", r"syntax error"),
    ("", r"empty expression"),
    ("   \n ", r"empty expression"),
    ("x" * (MAX_LENGTH + 1), rf"longer than {MAX_LENGTH} characters"),
    ("-" * 3000 + "x", r"nested too deeply"),
    ("sqrt(" * (MAX_DEPTH + 5) + "x" + ")" * (MAX_DEPTH + 5), r"nested more than"),
]


@pytest.mark.parametrize(("text", "match"), REFUSED, ids=[m for _, m in REFUSED])
def test_refused_constructs_name_the_problem(text, match):
    with pytest.raises(ExpressionError, match=match) as info:
        parse_expression(text)
    err = info.value
    assert isinstance(err, ValueError) and isinstance(err, RdmeshError)
    assert "\n" not in str(err)
    assert len(str(err)) < 300


def test_errors_carry_the_column():
    with pytest.raises(ExpressionError) as info:
        parse_expression("x + y + os")
    assert info.value.column == 9
    assert info.value.reason.startswith("unknown name 'os'")


def test_refused_text_is_never_run(tmp_path):
    marker = tmp_path / "ran"
    payloads = [
        f"__import__('os').system('touch {marker}')",
        f"open('{marker}', 'w')",
        f"[open('{marker}', 'w') for _ in (1,)]",
        f"(lambda: open('{marker}', 'w'))()",
    ]
    for text in payloads:
        with pytest.raises(ExpressionError):
            parse_expression(text)
        with pytest.raises(ValueError):
            ImplicitSurface.from_expression(text, bounding_sphere=((0, 0, 0), 2))
    assert not marker.exists()


def test_not_a_string():
    with pytest.raises(ExpressionError, match="expected a string"):
        parse_expression(3)  # type: ignore[arg-type]


# -- ImplicitSurface.from_expression -------------------------------------------------------


def test_from_expression_builds_a_surface():
    s = ImplicitSurface.from_expression(
        "(x-1)**2 + y**2 + z**2 - 1", bounding_sphere=((1, 0, 0), 2)
    )
    assert s.name == "(x-1)**2 + y**2 + z**2 - 1"
    assert s.radius == 2.0 and s.centre.tolist() == [1.0, 0.0, 0.0]
    p = np.array([[1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [3.0, 0.5, 0.0]])
    np.testing.assert_allclose(s(p), [-1.0, 0.0, 3.25])
    np.testing.assert_allclose(s.grad(p), 2 * (p - [1, 0, 0]))
    assert s.gradient is not None
    named = ImplicitSurface.from_expression("x - 1", ((0, 0, 0), 1), name="plane")
    assert named.name == "plane"


def test_from_expression_checks_the_sphere_and_the_text():
    with pytest.raises(ValueError, match="radius must be positive"):
        ImplicitSurface.from_expression("x**2 + y**2 + z**2 - 1", bounding_sphere=((0, 0, 0), 0))
    with pytest.raises(ExpressionError, match="unknown name 'w'"):
        ImplicitSurface.from_expression("x + w", bounding_sphere=((0, 0, 0), 1))


@pytest.mark.parametrize(
    ("text", "bound", "radius_bound", "euler"),
    [
        ("x**2 + y**2 + z**2 - 1", 2.0, 0.1, 2),
        ("(x**2 + y**2 + z**2 + 1 - 0.16)**2 - 4*(x**2 + y**2)", 2.0, 0.04, 0),
        ("(sqrt(x**2 + y**2) - 1)**2 + z**2 - 0.16", 2.0, 0.04, 0),
    ],
    ids=["sphere", "torus", "torus_sqrt"],
)
def test_meshing_an_expression_gives_the_right_topology(text, bound, radius_bound, euler):
    s = ImplicitSurface.from_expression(text, bounding_sphere=((0, 0, 0), bound))
    mesh = rdmesh.mesh_surface(s, radius_bound=radius_bound)
    topo = mesh.topology()
    assert topo["components"] == 1
    assert topo["euler"] == [euler]
    assert topo["closed_manifold"]
    tm = mesh.to_trimesh()
    assert tm.is_watertight and tm.is_winding_consistent
    assert tm.euler_number == euler
    assert np.max(np.abs(s.f(mesh.vertices))) < 1e-6
    assert mesh.min_angle >= 30.0 - 1e-6


def test_expression_sphere_matches_the_exact_sphere():
    s = ImplicitSurface.from_expression(
        "x*x + y*y + z*z - 0.81", bounding_sphere=((0.5, -0.5, 0.25), 2.0)
    )
    mesh = rdmesh.mesh_surface(s, radius_bound=0.08)
    r = np.linalg.norm(mesh.vertices, axis=1)
    np.testing.assert_allclose(r, 0.9, atol=1e-7)
    # The area of a fine enough mesh approaches 4 pi r^2 from below.
    area = mesh.to_trimesh().area
    assert 0.97 * 4 * math.pi * 0.81 < area < 4 * math.pi * 0.81


@pytest.mark.parametrize("n", [*range(-17, 0), *range(1, 18)])
def test_integer_powers_match_numpy_pow(n):
    # Small integer exponents are multiplied out; the result must stay within a
    # few ulps of pow (relative) or of the smallest normal (absolute).
    rng = np.random.default_rng(abs(n))
    x = np.concatenate(
        [rng.uniform(-3, 3, 2000), 10.0 ** rng.uniform(-80, 80, 500), [0.0, -0.0, 1.0, -1.0]]
    )
    e = parse_expression(f"x**({n})")
    zero = np.zeros_like(x)
    with np.errstate(all="ignore"):
        want = np.power(x, float(n))
        got = e(np.column_stack([x, zero, zero]))
        dwant = n * np.power(x, float(n - 1))
        # The exact derivative (gradient() replaces infinite ones by differences).
        dgot = pointwise.dual(e._root, (x, zero, zero))[1][0]
    for a, b in ((got, want), (dgot, dwant)):
        fin = np.isfinite(b)
        assert np.array_equal(np.isfinite(a), fin)
        assert np.array_equal(np.signbit(a[fin & (b != 0)]), np.signbit(b[fin & (b != 0)]))
        err = np.abs(a[fin] - b[fin])
        assert (err <= 2.0**-49 * np.abs(b[fin]) + np.finfo(float).tiny).all()
        inf = ~fin & ~np.isnan(b)
        assert np.array_equal(a[inf], b[inf])
