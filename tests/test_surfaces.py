"""The built-in surfaces: analytic gradients agree with f."""

import numpy as np
import pytest
from rdmesh.surfaces import SURFACES


@pytest.mark.parametrize("name", list(SURFACES))
def test_gradient_matches_central_differences(name):
    surface = SURFACES[name].make()
    if surface.gradient is None:
        pytest.skip("no analytic gradient")
    rng = np.random.default_rng(3)
    c, r = surface.centre, surface.radius
    p = c + rng.uniform(-0.7, 0.7, (2000, 3)) * r
    h = 1e-5 * r
    fd = np.column_stack(
        [(surface.f(p + h * e) - surface.f(p - h * e)) / (2 * h) for e in np.eye(3)]
    )
    g = surface.gradient(p)
    assert g.shape == (len(p), 3)
    scale = np.linalg.norm(fd, axis=1).max()
    np.testing.assert_allclose(g, fd, rtol=1e-5, atol=1e-6 * scale)


@pytest.mark.parametrize("name", ["torus", "tanglecube", "double_torus"])
def test_differences_of_f_alone_match_the_gradient(name):
    """Without a gradient function: central differences (six evaluations per
    point) and forward ones (four) both match the analytic gradient."""
    import rdmesh
    from rdmesh.surfaces.oracle import forward_gradient

    base = SURFACES[name].make()
    s = rdmesh.ImplicitSurface(base.f, base.bounding_sphere)
    rng = np.random.default_rng(4)
    p = base.centre + rng.uniform(-0.7, 0.7, (2000, 3)) * base.radius
    exact = base.gradient(p)
    scale = np.linalg.norm(exact, axis=1).max()
    for grad, per_point, tol in ((s.grad, 6, 1e-7), (lambda q: forward_gradient(s, q), 4, 1e-4)):
        before = s.evaluations
        g = grad(p)
        assert s.evaluations - before == per_point * len(p)
        np.testing.assert_allclose(g, exact, rtol=tol, atol=tol * scale)
    # A given gradient is used as it is.
    np.testing.assert_array_equal(forward_gradient(base, p), base.gradient(p))
