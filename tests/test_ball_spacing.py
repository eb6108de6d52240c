"""The protecting balls' default spacing on mesh inputs (rdmesh.refine.ball_spacing)."""

from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import rdmesh
from rdmesh.refine.ball_spacing import SMALL_BALL_COST, small_balls, small_by_default
from rdmesh.refine.criteria import SMALL_BALL


def _surface(curve_length: float, area: float, **kw):
    """A stand-in with one straight sharp curve and two triangles of ``area``."""
    side = np.sqrt(area)
    v = np.array([[0, 0, 0], [side, 0, 0], [side, side, 0], [0, side, 0]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    fields = dict(
        sharp_curves=[np.array([[0.0, 0, 0], [curve_length, 0, 0]])], features=[], holes=None,
        vertices=v, faces=f, input_face_count=2,
    )  # fmt: skip
    fields.update(kw)
    return SimpleNamespace(**fields)


def test_small_balls_by_default_only_where_they_add_few_vertices():
    r, area = 0.01, 1.0
    # Balls SMALL_BALL r apart along the curve against the area / r^2 vertices.
    fits = SMALL_BALL_COST * area / r**2 * SMALL_BALL * r
    assert small_by_default(_surface(0.99 * fits, area), r)
    assert not small_by_default(_surface(1.01 * fits, area), r)
    short = _surface(0.5 * fits, area)
    assert not small_by_default(short, None)
    assert not small_by_default(short, lambda x: np.full(len(x), r))
    assert not small_by_default(_surface(0.5 * fits, area, sharp_curves=[]), r)
    given = _surface(0.5 * fits, area, features=[np.zeros((2, 3))])
    assert not small_by_default(given, r)
    rims = _surface(0.5 * fits, area, holes=SimpleNamespace(curves=[np.zeros((3, 3))]))
    assert not small_by_default(rims, r)


def test_a_short_crease_gets_small_balls_and_30_degrees_by_default():
    """The thin-handled genus-2 solid's crease (where its two tori meet) is
    short against its area: by default its balls are small and the angle
    bound holds next to them; with balls the radius bound apart it does not."""
    pytest.importorskip("skimage")
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import real_data

    v, f = real_data.genus2_thin(0.03)
    r = 0.02 * float(np.linalg.norm(np.ptp(v, axis=0)))
    s = rdmesh.MeshSurface((v, f))
    assert small_by_default(s, r)
    small = rdmesh.mesh_surface(s, radius_bound=r, distance_bound=r / 10)
    wide = rdmesh.mesh_surface(s, radius_bound=r, distance_bound=r / 10, edge_size=r)
    for m in (small, wide):
        assert m.features.held and m.complete and m.report["euler"] == [-2]
    assert small.angles.min() >= 29.99
    assert (wide.angles < 29.99).sum() > 0
    assert small.features.angle_held and not wide.features.angle_held
    assert "held" in small.report["features"]["angle_at_balls"]
    assert "relaxed" in wide.report["features"]["angle_at_balls"]
    assert "angle bound held" in small.summary() and "angle bound held" not in wide.summary()


def test_balls_are_small_only_against_a_numeric_radius_bound():
    assert small_balls(0.03, 0.1) and not small_balls(0.04, 0.1)
    assert not small_balls(None, 0.1) and not small_balls(0.03, None)
    assert not small_balls(lambda x: x, 0.1) and not small_balls(0.03, lambda x: x)


def test_an_edge_size_without_a_radius_bound_is_meshed():
    """The topological-ball method needs no radius bound: a given edge_size
    there used to raise TypeError (the spacing compared against None)."""
    s = rdmesh.ImplicitSurface.from_expression("x**2+y**2+z**2-1", ((0, 0, 0), 2.0))
    m = rdmesh.mesh_surface(s, method="topological-ball", edge_size=0.1)
    assert m.complete and m.report["euler"] == [2]
