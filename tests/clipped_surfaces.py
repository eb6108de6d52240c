"""Surfaces that leave their bounding sphere, for the clipped tests and benchmarks.

Each meshes to a manifold with boundary with ``topology="manifold-with-boundary"``:

- :func:`plane`: a tilted plane through the unit ball: a disk, one boundary loop;
- :func:`cylinder`: a cylinder of radius 0.5 along z, longer than the unit
  ball: an annulus, two loops;
- :func:`torus_off_centre`: a torus (radii 0.6 and 0.2) centred at (1, 0, 0),
  cut in half by the unit sphere: an annulus, two loops;
- :data:`GYROID` in a sphere of radius 2: a gyroid-like lattice with many
  loops (its topology is not known in closed form).

And clipped to an axis-aligned box (``ImplicitSurface(..., clip_box=...)``):

- :data:`GYROID_2PI` (period 2 pi) in :data:`GYROID_BOX`, a cube of side 6.6
  off the gyroid's symmetry centre (as ``tests/test_clip_box_expression.py``):
  the curve crosses the box edges away from the corners; topology not known
  in closed form;
- :func:`tilted_plane` in :data:`PLANE_BOX`: a pentagon (it meets four side
  faces and the top face), a disk with one boundary loop.

:data:`CASES` lists them with their bounding sphere or box and known
topology; the CGAL reference program (``benchmarks/cgal_reference``) has the
same surfaces as ``clipped_plane``, ``clipped_cylinder``,
``clipped_half_torus``, ``clipped_gyroid`` (sphere) and ``box_gyroid``,
``box_plane`` (box, the same boxes: keep them equal).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

GYROID = "sin(3*x)*cos(3*y) + sin(3*y)*cos(3*z) + sin(3*z)*cos(3*x)"
GYROID_2PI = "sin(x)*cos(y) + sin(y)*cos(z) + sin(z)*cos(x)"
#: ``[lo, hi]`` of the box cases.
GYROID_BOX = ((-3.0, -3.5, -3.2), (3.6, 3.1, 3.4))
PLANE_BOX = ((-0.8, -0.7, -0.5), (0.9, 0.6, 0.6))


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


def tilted_plane(p: np.ndarray) -> np.ndarray:
    """``z - 0.2 - 0.5 x - 0.2 y``: a pentagon in :data:`PLANE_BOX` (z reaches
    its top face near the corner x = 0.9, y = 0.6)."""
    return p[:, 2] - 0.2 - 0.5 * p[:, 0] - 0.2 * p[:, 1]


@dataclass(frozen=True)
class ClippedCase:
    """A clipped surface of known topology (None: not known).

    ``f`` is a numpy function of (N, 3) points or an expression string;
    ``radius`` that of the bounding sphere about the origin; ``cgal`` the
    surface's name in the CGAL reference program.  With a ``box`` (``(lo,
    hi)``) the surface is clipped to that box instead (``clip_box``), in the
    box's circumscribed sphere enlarged by 10% (as the command line's);
    ``radius`` is None then.
    """

    f: object
    radius: float | None
    cgal: str
    components: int | None
    euler: int | None
    loops: int | None
    box: tuple | None = None

    def sphere(self) -> tuple[np.ndarray, float]:
        """The bounding sphere ``(centre, radius)`` the case's surface gets."""
        if self.box is None:
            return np.zeros(3), float(self.radius)
        lo, hi = np.asarray(self.box, float)
        return 0.5 * (lo + hi), 1.1 * 0.5 * float(np.linalg.norm(hi - lo))

    def surface(self):
        """The ``rdmesh.ImplicitSurface`` of the case."""
        import rdmesh

        sphere = self.sphere()
        box = None if self.box is None else np.asarray(self.box, float)
        if isinstance(self.f, str):
            return rdmesh.ImplicitSurface.from_expression(self.f, sphere, clip_box=box)
        return rdmesh.ImplicitSurface(self.f, sphere, clip_box=box)


CASES = {
    "gyroid in a sphere": ClippedCase(GYROID, 2.0, "clipped_gyroid", None, None, None),
    "plane disk": ClippedCase(plane, 1.0, "clipped_plane", 1, 1, 1),
    "long cylinder": ClippedCase(cylinder, 1.0, "clipped_cylinder", 1, 0, 2),
    "half torus": ClippedCase(torus_off_centre, 1.0, "clipped_half_torus", 1, 0, 2),
    "gyroid in a cube": ClippedCase(
        GYROID_2PI, None, "box_gyroid", None, None, None, box=GYROID_BOX
    ),
    "plane in a box": ClippedCase(tilted_plane, None, "box_plane", 1, 1, 1, box=PLANE_BOX),
}
