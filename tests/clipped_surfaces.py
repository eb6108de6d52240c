"""Surfaces that leave their bounding sphere, for the clipped tests and benchmarks.

Each meshes to a manifold with boundary with ``topology="manifold-with-boundary"``:

- :func:`plane`: a tilted plane through the unit ball: a disk, one boundary loop;
- :func:`cylinder`: a cylinder of radius 0.5 along z, longer than the unit
  ball: an annulus, two loops;
- :func:`torus_off_centre`: a torus (radii 0.6 and 0.2) centred at (1, 0, 0),
  cut in half by the unit sphere: an annulus, two loops;
- :data:`GYROID` in a sphere of radius 2: a gyroid-like lattice with many
  loops (its topology is not known in closed form).

:data:`CASES` lists them with their bounding sphere and known topology; the
CGAL reference program (``benchmarks/cgal_reference``) has the same four
surfaces as ``clipped_plane``, ``clipped_cylinder``, ``clipped_half_torus``
and ``clipped_gyroid``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

GYROID = "sin(3*x)*cos(3*y) + sin(3*y)*cos(3*z) + sin(3*z)*cos(3*x)"


def plane(p: np.ndarray) -> np.ndarray:
    """``z - 0.3 - 0.1 x``: a disk in the unit ball."""
    return p[:, 2] - 0.3 - 0.1 * p[:, 0]


def cylinder(p: np.ndarray) -> np.ndarray:
    """``x^2 + y^2 - 0.25``: an annulus in the unit ball (two loops at |z| = sqrt(0.75))."""
    return p[:, 0] ** 2 + p[:, 1] ** 2 - 0.25


def torus_off_centre(p: np.ndarray) -> np.ndarray:
    """A torus (radii 0.6 and 0.2) centred at (1, 0, 0): the unit ball holds
    one piece of its tube, an annulus."""
    q = np.sqrt((p[:, 0] - 1.0) ** 2 + p[:, 1] ** 2) - 0.6
    return q * q + p[:, 2] ** 2 - 0.04


@dataclass(frozen=True)
class ClippedCase:
    """A clipped surface of known topology (None: not known).

    ``f`` is a numpy function of (N, 3) points or an expression string;
    ``radius`` that of the bounding sphere about the origin; ``cgal`` the
    surface's name in the CGAL reference program.
    """

    f: object
    radius: float
    cgal: str
    components: int | None
    euler: int | None
    loops: int | None

    def surface(self):
        """The ``rdmesh.ImplicitSurface`` of the case."""
        import rdmesh

        sphere = ((0.0, 0.0, 0.0), self.radius)
        if isinstance(self.f, str):
            return rdmesh.ImplicitSurface.from_expression(self.f, sphere)
        return rdmesh.ImplicitSurface(self.f, sphere)


CASES = {
    "gyroid in a sphere": ClippedCase(GYROID, 2.0, "clipped_gyroid", None, None, None),
    "plane disk": ClippedCase(plane, 1.0, "clipped_plane", 1, 1, 1),
    "long cylinder": ClippedCase(cylinder, 1.0, "clipped_cylinder", 1, 0, 2),
    "half torus": ClippedCase(torus_off_centre, 1.0, "clipped_half_torus", 1, 0, 2),
}
