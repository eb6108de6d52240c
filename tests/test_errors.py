"""Bad inputs and budgets: each raises a specific exception with a useful message."""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
from rdmesh import (
    BoundingSphereError,
    BudgetExceeded,
    EmptySurfaceError,
    ImplicitSurface,
    OracleError,
    RdmeshError,
)
from rdmesh.surfaces import SURFACES


def _sphere_f(p):
    return np.einsum("ij,ij->i", p, p) - 1.0


def _sphere(f=_sphere_f, radius=2.0, **kw):
    return ImplicitSurface(f, ((0.0, 0.0, 0.0), radius), **kw)


def _raises(p):
    raise ZeroDivisionError("boom")


def _nan_far(p):
    out = _sphere_f(p)
    out[p[:, 0] > 1.5] = np.nan
    return out


# -- the surface function misbehaves --------------------------------------------

ORACLE_CASES = [
    ("nan", lambda p: np.full(len(p), np.nan), r"returned nan"),
    ("nan_somewhere", _nan_far, r"returned nan"),
    ("inf", lambda p: _sphere_f(p) + np.where(p[:, 2] > 0, np.inf, 0.0), r"returned inf"),
    ("minus_inf", lambda p: np.full(len(p), -np.inf), r"returned -inf"),
    ("wrong_shape_2d", lambda p: p[:, :2], r"shape"),
    ("wrong_shape_column", lambda p: _sphere_f(p)[:, None], r"shape"),
    ("wrong_length", lambda p: _sphere_f(p)[:-1], r"shape"),
    ("scalar", lambda p: 1.0, r"shape"),
    ("raises", _raises, r"raised ZeroDivisionError: boom"),
    ("strings", lambda p: np.array(["a"] * len(p)), r"non-numbers"),
]


@pytest.mark.parametrize(("f", "match"), [pytest.param(f, m, id=i) for i, f, m in ORACLE_CASES])
def test_bad_surface_function(f, match):
    with pytest.raises(OracleError, match=match) as info:
        rdmesh.mesh_surface(_sphere(f), radius_bound=0.2)
    assert isinstance(info.value, ValueError)
    assert isinstance(info.value, RdmeshError)


def test_oracle_error_keeps_cause():
    with pytest.raises(OracleError) as info:
        rdmesh.mesh_surface(_sphere(_raises), radius_bound=0.2)
    assert isinstance(info.value.__cause__, ZeroDivisionError)


@pytest.mark.parametrize(
    ("gradient", "match"),
    [
        pytest.param(lambda p: p[:, :2], r"gradient function must return", id="shape"),
        pytest.param(
            lambda p: np.full((len(p), 3), np.nan), r"gradient function must return", id="nan"
        ),
        pytest.param(_raises, r"gradient function raised ZeroDivisionError", id="raises"),
    ],
)
def test_bad_gradient(gradient, match):
    with pytest.raises(OracleError, match=match):
        rdmesh.mesh_surface(_sphere(gradient=gradient), radius_bound=0.2)


# -- the surface and the bounding sphere ------------------------------------------


def test_empty_surface():
    s = _sphere(lambda p: np.einsum("ij,ij->i", p, p) + 1.0)
    with pytest.raises(EmptySurfaceError, match=r"no surface found"):
        rdmesh.mesh_surface(s, radius_bound=0.2)


def test_surface_crossing_bounding_sphere():
    s = _sphere(radius=0.8)  # the unit sphere does not fit
    with pytest.raises(BoundingSphereError, match=r"bounding sphere"):
        rdmesh.mesh_surface(s, radius_bound=0.2)


def test_sign_flipped():
    s = _sphere(lambda p: 1.0 - np.einsum("ij,ij->i", p, p))
    with pytest.raises(BoundingSphereError, match=r"flip the sign"):
        rdmesh.mesh_surface(s, radius_bound=0.2)


def test_surface_error_types_are_value_errors():
    assert issubclass(EmptySurfaceError, ValueError)
    assert issubclass(BoundingSphereError, ValueError)
    assert issubclass(OracleError, ValueError)
    assert issubclass(rdmesh.CGALError, RuntimeError)
    assert not issubclass(BudgetExceeded, ValueError)


def test_ctrl_c_is_not_a_budget_stop():
    # Catching a budget stop to go on with the partial mesh must not swallow
    # Ctrl-C; StoppedEarly catches every early stop with its mesh.
    assert not issubclass(rdmesh.Interrupted, BudgetExceeded)
    for cls in (BudgetExceeded, rdmesh.Interrupted, rdmesh.RefinementStalled):
        assert issubclass(cls, rdmesh.StoppedEarly)
        exc = cls("stopped", mesh="the mesh", reason="why")
        assert (exc.mesh, exc.reason, str(exc)) == ("the mesh", "why", "stopped")


@pytest.mark.parametrize(
    ("sphere", "match"),
    [
        pytest.param(((0, 0, 0), -1.0), r"radius must be positive", id="negative_radius"),
        pytest.param(((0, 0, 0), 0.0), r"radius must be positive", id="zero_radius"),
        pytest.param(((0, 0, 0), np.inf), r"radius must be positive", id="inf_radius"),
        pytest.param(((0, 0, 0), "big"), r"radius must be a number", id="str_radius"),
        pytest.param(((0, 0), 2.0), r"centre must be 3 finite numbers", id="centre_2d"),
        pytest.param(((0, 0, 0, 0), 2.0), r"centre must be 3 finite numbers", id="centre_4d"),
        pytest.param(((0, np.nan, 0), 2.0), r"centre must be 3 finite numbers", id="centre_nan"),
        pytest.param(5.0, r"pair", id="not_a_pair"),
        pytest.param(((0, 0, 0), 1.0, 2.0), r"pair", id="triple"),
    ],
)
def test_bad_bounding_sphere(sphere, match):
    with pytest.raises(ValueError, match=match):
        ImplicitSurface(_sphere_f, sphere)


def test_surface_must_be_callable():
    with pytest.raises(ValueError, match=r"f must be callable"):
        ImplicitSurface(42, ((0, 0, 0), 2.0))
    with pytest.raises(ValueError, match=r"gradient must be callable"):
        ImplicitSurface(_sphere_f, ((0, 0, 0), 2.0), gradient="grad")


# -- options ----------------------------------------------------------------------

OPTION_CASES = [
    ("radius_negative", {"radius_bound": -0.1}, r"radius_bound must be positive"),
    ("radius_zero", {"radius_bound": 0.0}, r"radius_bound must be positive"),
    ("radius_nan", {"radius_bound": np.nan}, r"radius_bound must be positive"),
    ("radius_inf", {"radius_bound": np.inf}, r"radius_bound must be positive"),
    ("radius_str", {"radius_bound": "small"}, r"radius_bound must be a number"),
    ("angle_31", {"angle_bound": 31.0}, r"angle_bound 31.0 is above 30"),
    ("angle_negative", {"angle_bound": -1.0}, r"angle_bound must be finite and >= 0"),
    ("angle_nan", {"angle_bound": np.nan}, r"angle_bound must be finite"),
    ("angle_str", {"angle_bound": "sharp"}, r"angle_bound must be a number"),
    ("distance_zero", {"distance_bound": 0.0}, r"distance_bound must be positive"),
    ("distance_negative", {"distance_bound": -1e-3}, r"distance_bound must be positive"),
    ("distance_nan", {"distance_bound": np.nan}, r"distance_bound must be positive"),
    ("method", {"method": "cgal"}, r"unknown method 'cgal'"),
    ("topology", {"topology": "closed"}, r"unknown topology 'closed'"),
    ("max_vertices_zero", {"max_vertices": 0}, r"max_vertices must be a positive integer"),
    ("max_vertices_float", {"max_vertices": 2.5}, r"max_vertices must be a positive integer"),
    ("max_vertices_bool", {"max_vertices": True}, r"max_vertices must be a positive integer"),
    ("time_limit_zero", {"time_limit": 0}, r"time_limit must be a positive number"),
    ("time_limit_nan", {"time_limit": np.nan}, r"time_limit must be a positive number"),
    ("seed_resolution_small", {"seed_resolution": 4}, r"seed_resolution must be an integer"),
    ("seed_resolution_float", {"seed_resolution": 32.5}, r"seed_resolution must be an integer"),
    ("seed_str", {"seed": "abc"}, r"seed must be an integer"),
]


@pytest.mark.parametrize(
    ("kwargs", "match"), [pytest.param(k, m, id=i) for i, k, m in OPTION_CASES]
)
def test_bad_options(kwargs, match):
    calls = []

    def f(p):
        calls.append(len(p))
        return _sphere_f(p)

    with pytest.raises(ValueError, match=match):
        rdmesh.mesh_surface(_sphere(f), **kwargs)
    assert calls == []  # options are checked before any work


def test_surface_must_be_implicit_surface():
    with pytest.raises(ValueError, match=r"must be an rdmesh.ImplicitSurface"):
        rdmesh.mesh_surface(_sphere_f, radius_bound=0.1)


@pytest.mark.parametrize(
    "sizing",
    [
        pytest.param(lambda p: -np.ones(len(p)), id="negative"),
        pytest.param(lambda p: np.zeros(len(p)), id="zero"),
        pytest.param(lambda p: np.ones(len(p) + 1), id="wrong_length"),
        pytest.param(lambda p: np.full(len(p), np.nan), id="nan"),
    ],
)
def test_bad_sizing_field(sizing):
    with pytest.raises(ValueError, match=r"sizing field must return one positive finite radius"):
        rdmesh.mesh_surface(_sphere(), radius_bound=sizing)


def test_sizing_field_that_raises():
    with pytest.raises(ValueError, match=r"sizing field raised ZeroDivisionError"):
        rdmesh.mesh_surface(_sphere(), radius_bound=_raises)


def test_unknown_builtin_surface():
    with pytest.raises(ValueError, match=r"unknown surface 'klein'"):
        rdmesh.surfaces.get("klein")
    # Spelling variants of a known name are accepted.
    assert rdmesh.surfaces.get("Two-Spheres").name == "two spheres"


# -- budgets ----------------------------------------------------------------------


def _assert_partial(exc: BudgetExceeded, reason: str, max_vertices: int | None = None):
    m = exc.mesh
    assert isinstance(m, rdmesh.SurfaceMesh)
    assert m.complete is False
    assert reason in exc.reason
    assert m.stats["stop_reason"] == exc.reason
    assert reason in str(exc)
    if max_vertices is not None:
        assert m.stats["samples"] <= max_vertices
        assert len(m.vertices) <= max_vertices
    # Whatever is there is still a valid face list on the reported vertices.
    assert m.faces.min() >= 0 and m.faces.max() < len(m.vertices)


def test_max_vertices_midway(sphere_case):
    """A cap between the seed count and the final count stops refinement."""
    full = sphere_case.mesh
    seeds = full.stats["inserted"]["seeds"]
    assert seeds < len(full.vertices)
    cap = (seeds + len(full.vertices)) // 2
    with pytest.raises(BudgetExceeded) as info:
        rdmesh.mesh_surface(SURFACES["sphere"].make(), radius_bound=0.1, max_vertices=cap)
    _assert_partial(info.value, "max_vertices", cap)
    assert info.value.mesh.stats["samples"] == cap


def test_max_vertices_below_seed_count(sphere_case):
    """A cap smaller than the initial sample is honoured too."""
    cap = 10
    assert sphere_case.mesh.stats["inserted"]["seeds"] > cap
    with pytest.raises(BudgetExceeded) as info:
        rdmesh.mesh_surface(SURFACES["sphere"].make(), radius_bound=0.1, max_vertices=cap)
    _assert_partial(info.value, "max_vertices", cap)


def test_generous_max_vertices_is_not_hit(sphere_case):
    n = len(sphere_case.mesh.vertices)
    m = rdmesh.mesh_surface(SURFACES["sphere"].make(), radius_bound=0.1, max_vertices=n)
    assert m.complete
    assert np.array_equal(m.faces, sphere_case.mesh.faces)


def test_time_limit():
    with pytest.raises(BudgetExceeded) as info:
        rdmesh.mesh_surface(SURFACES["torus"].make(), radius_bound=0.04, time_limit=1e-6)
    _assert_partial(info.value, "time_limit")
