"""Triangle quality and circumcentres (rdmesh._geometry) and the facet criteria."""

from __future__ import annotations

import math

import numpy as np
import pytest
from meshcheck import circumcentre_ref, triangle_angles_deg
from rdmesh._geometry import circumcentres, circumradii, min_angles, sin2_min_angle
from rdmesh.refine.criteria import FacetCriteria


def _random_triangles(n, seed=0):
    rng = np.random.default_rng(seed)
    corners = rng.normal(size=(n, 3, 3)) * rng.uniform(1e-3, 1e3, (n, 1, 1))
    return corners + rng.uniform(-10, 10, (n, 1, 3))


def _triangle_with_angles(alpha_deg, beta_deg, scale=1.0):
    """A triangle in a tilted plane with angles alpha at A and beta at B."""
    a, b = math.radians(alpha_deg), math.radians(beta_deg)
    c = math.pi - a - b
    # Law of sines: |AC| = sin(b)/sin(c) for |AB| = 1.
    ac = math.sin(b) / math.sin(c)
    pts = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [ac * math.cos(a), ac * math.sin(a), 0.0]])
    q, _ = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))
    return scale * pts @ q.T + np.array([0.3, -2.0, 5.0])


def test_sin2_min_angle_matches_arccos():
    corners = _random_triangles(2000)
    angles = triangle_angles_deg(corners)
    expect = np.sin(np.radians(angles.min(axis=1))) ** 2
    assert np.allclose(sin2_min_angle(corners), expect, rtol=1e-9, atol=1e-12)
    assert np.allclose(min_angles(corners), angles.min(axis=1), atol=1e-7)


def test_min_angle_of_known_triangles():
    for alpha, beta in [(60, 60), (30, 60), (10, 80), (45, 45), (1, 1), (29.5, 100)]:
        t = _triangle_with_angles(alpha, beta, scale=0.01)[None]
        assert min_angles(t)[0] == pytest.approx(min(alpha, beta, 180 - alpha - beta), abs=1e-8)
    # Invariant under vertex order and scale.
    t = _triangle_with_angles(20, 70)[None]
    for perm in ([1, 2, 0], [2, 1, 0]):
        assert sin2_min_angle(t[:, perm])[0] == pytest.approx(sin2_min_angle(t)[0], rel=1e-12)
    assert sin2_min_angle(1e-4 * t)[0] == pytest.approx(sin2_min_angle(t)[0], rel=1e-9)


def test_degenerate_triangles_have_zero_quality():
    collinear = np.array([[[0.0, 0, 0], [1.0, 0, 0], [3.0, 0, 0]]])
    repeated = np.array([[[1.0, 2, 3], [1.0, 2, 3], [0.0, 0, 1]]])
    point = np.zeros((1, 3, 3))
    for t in (collinear, repeated, point):
        with np.errstate(all="raise"):
            q = sin2_min_angle(t)
        assert q[0] == 0.0
        assert min_angles(t)[0] == 0.0


def test_circumcentres_equidistant_and_coplanar():
    corners = _random_triangles(2000, seed=2)
    angles = triangle_angles_deg(corners)
    corners = corners[angles.min(axis=1) > 1.0]  # well-conditioned ones
    cc = circumcentres(corners)
    d = np.linalg.norm(cc[:, None, :] - corners, axis=2)
    assert np.allclose(d, d[:, :1], rtol=1e-9)
    n = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    n /= np.linalg.norm(n, axis=1)[:, None]
    off_plane = np.abs(np.einsum("ij,ij->i", cc - corners[:, 0], n))
    assert np.all(off_plane <= 1e-9 * d[:, 0])
    assert np.allclose(cc, circumcentre_ref(corners), rtol=0, atol=1e-9 * d.max())
    # Circumradius = abc / (4 area).
    e = np.linalg.norm(corners - corners[:, [1, 2, 0]], axis=2)
    area = 0.5 * np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )
    assert np.allclose(circumradii(corners), e.prod(axis=1) / (4 * area), rtol=1e-9)


def test_right_triangle_circumcentre_is_hypotenuse_midpoint():
    t = np.array([[[0.0, 0, 0], [2.0, 0, 0], [0.0, 1.0, 0]]])
    assert np.allclose(circumcentres(t), [[1.0, 0.5, 0.0]])
    assert circumradii(t)[0] == pytest.approx(math.sqrt(1.25))


# -- FacetCriteria ---------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"angle_bound": 30.0001}, r"above 30"),
        ({"angle_bound": 45}, r"above 30"),
        ({"angle_bound": -0.5}, r">= 0"),
        ({"angle_bound": math.inf}, r"finite"),
        ({"angle_bound": None}, r"must be a number"),
        ({"radius_bound": 0}, r"radius_bound must be positive"),
        ({"radius_bound": -2}, r"radius_bound must be positive"),
        ({"radius_bound": math.nan}, r"radius_bound must be positive"),
        ({"radius_bound": [0.1]}, r"radius_bound must be a number"),
        ({"distance_bound": 0}, r"distance_bound must be positive"),
        ({"distance_bound": math.inf}, r"distance_bound must be positive"),
    ],
)
def test_criteria_rejects(kwargs, match):
    with pytest.raises(ValueError, match=match):
        FacetCriteria(**kwargs)


def test_criteria_accepts_and_normalises():
    c = FacetCriteria(30, 1, 2)
    assert (c.angle_bound, c.radius_bound, c.distance_bound) == (30.0, 1.0, 2.0)
    assert isinstance(c.radius_bound, float)
    assert FacetCriteria(0.0).angle_bound == 0.0
    psi = FacetCriteria(radius_bound=lambda p: 0.5 + p[:, 0] ** 2)
    assert np.allclose(psi.sizing(np.array([[1.0, 0, 0], [0.0, 5, 0]])), [1.5, 0.5])
    assert FacetCriteria().sizing(np.zeros((3, 3))) is None


def _facet(alpha, beta, scale=0.1):
    """Corners, a surface centre on the dual line at height h, and its radius."""
    corners = _triangle_with_angles(alpha, beta, scale)[None]
    cc = circumcentres(corners)
    n = np.cross(corners[0, 1] - corners[0, 0], corners[0, 2] - corners[0, 0])
    n /= np.linalg.norm(n)
    return corners, cc, n


def test_angle_criterion_threshold():
    c = FacetCriteria(angle_bound=30.0)
    for angle, bad in [(29.9, True), (30.1, False), (60.0, False), (5.0, True)]:
        corners, cc, _ = _facet(angle, 80.0)
        r = np.linalg.norm(cc - corners[:, 0], axis=1)
        assert c.bad(corners, cc, r).tolist() == [bad]
    # Angle 0 switches the criterion off.
    corners, cc, _ = _facet(1.0, 80.0)
    r = np.linalg.norm(cc - corners[:, 0], axis=1)
    assert FacetCriteria(angle_bound=0.0).bad(corners, cc, r).tolist() == [False]


def test_radius_criterion_constant_and_field():
    corners, cc, n = _facet(60, 60, scale=1.0)
    rho = np.linalg.norm(cc - corners[:, 0], axis=1)[0]
    centre = cc + 0.2 * n  # farther along the dual: a larger ball
    r = np.linalg.norm(centre - corners[:, 0], axis=1)
    assert r[0] == pytest.approx(math.hypot(rho, 0.2))
    assert FacetCriteria(0, radius_bound=r[0] * 1.001).bad(corners, centre, r).tolist() == [False]
    assert FacetCriteria(0, radius_bound=r[0] * 0.999).bad(corners, centre, r).tolist() == [True]
    # A sizing field is evaluated at the surface centre, not at the corners.
    seen = []

    def field(p):
        seen.append(p.copy())
        return np.where(p[:, 0] > centre[0, 0] - 1e-12, r[0] * 0.5, 10.0)

    assert FacetCriteria(0, radius_bound=field).bad(corners, centre, r).tolist() == [True]
    assert np.array_equal(seen[0], centre)


def test_distance_criterion():
    corners, cc, n = _facet(50, 70, scale=1.0)
    for h, bound, bad in [(0.01, 0.02, False), (0.03, 0.02, True), (0.0, 1e-6, False)]:
        centre = cc + h * n
        r = np.linalg.norm(centre - corners[:, 0], axis=1)
        got = FacetCriteria(0, distance_bound=bound).bad(corners, centre, r)
        assert got.tolist() == [bad]


def _slack(d, a, b):
    """Least size and distance bounds a d and b d."""
    return np.array([a * d]), np.array([b * d])


def test_slack_raises_the_size_and_distance_bounds_to_its_share():
    """Where the output is cut off afterwards (a tent's facets), the size bound
    is at least a * d and the distance bound at least b * d."""
    corners, cc, n = _facet(60, 60, scale=1.0)
    centre = cc + 0.03 * n
    r = np.linalg.norm(centre - corners[:, 0], axis=1)
    crit = FacetCriteria(0, radius_bound=0.5 * r[0], distance_bound=0.01)
    assert crit.bad(corners, centre, r).tolist() == [True]
    assert crit.bad(corners, centre, r, slack=_slack(0.0, 0.5, 0.05)).tolist() == [True]
    roomy = _slack(4.0 * r[0], 0.5, 0.05)  # size 2 r, distance 0.2 r
    assert crit.bad(corners, centre, r, slack=roomy).tolist() == [False]
    # Each bound alone: too little room for the size, then for the distance.
    assert crit.bad(corners, centre, r, slack=_slack(1.9 * r[0], 0.5, 1.0)).tolist() == [True]
    far = _slack(4.0 * r[0], 0.5, 0.2 * 0.03 / r[0])
    assert crit.bad(corners, centre, r, slack=far).tolist() == [True]


def test_criteria_on_many_facets_is_elementwise():
    rng = np.random.default_rng(3)
    corners = _random_triangles(500, seed=4)
    cc = circumcentres(corners)
    n = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    n /= np.linalg.norm(n, axis=1)[:, None]
    centre = cc + rng.uniform(-1, 1, (500, 1)) * n
    r = np.linalg.norm(centre - corners[:, 0], axis=1)
    crit = FacetCriteria(25.0, radius_bound=np.median(r), distance_bound=0.5)
    angles = triangle_angles_deg(corners).min(axis=1)
    expect = (angles < 25.0) | (r > np.median(r)) | (np.linalg.norm(centre - cc, axis=1) > 0.5)
    got = crit.bad(corners, centre, r)
    close = np.abs(angles - 25.0) < 1e-6  # avoid rounding at the threshold
    assert np.array_equal(got[~close], expect[~close])
    assert 50 < expect.sum() < 450
    assert crit.bad(np.zeros((0, 3, 3)), np.zeros((0, 3)), np.zeros(0)).shape == (0,)
