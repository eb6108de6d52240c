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
