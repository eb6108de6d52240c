"""Volumes whose isosurface leaves their box, for ``VolumeSurface(border="clipped")``.

Each expression is sampled over a box smaller than its shape (see
:func:`volume`), so the mesh is the part inside the box, with a boundary on
its faces. Used by ``tests/test_volume_clipped.py`` and
``scripts/volume_clipped_figures.py``.
"""

from __future__ import annotations

import numpy as np
import rdmesh
import volumes

LO, HI = np.array([-1.0, -1.0, -1.0]), np.array([1.0, 1.0, 1.0])


def volume(f, lo=LO, hi=HI, n: int = 24, border: str = "clipped") -> rdmesh.VolumeSurface:
    """``-f`` sampled on an ``n``-per-axis grid over the box ``[lo, hi]``, isovalue 0."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    spacing = (hi - lo) / (n - 1)
    pts = volumes.grid((n, n, n), spacing, lo).reshape(-1, 3)
    vol = -f(pts).reshape(n, n, n)
    return rdmesh.VolumeSurface(
        vol, spacing=spacing, origin=lo, isovalue=0.0, border=border, name="clipped"
    )


def plane(p):
    """A tilted plane: a disk in the box, crossing its 4 vertical edges."""
    return p[:, 2] - 0.13 - 0.1 * p[:, 0]


def cylinder(p):
    """A cylinder along z, longer than the box: an annulus."""
    return np.hypot(p[:, 0], p[:, 1]) - 0.55


def corner_sphere(p):
    """A sphere about (0.7, 0.7, 0.7): the box corner (1, 1, 1) cuts a cap off."""
    return np.linalg.norm(p - 0.7, axis=1) - 0.8


def torus(p):
    """A torus about the z axis (radii 0.6 and 0.25)."""
    return np.hypot(np.hypot(p[:, 0], p[:, 1]) - 0.6, p[:, 2]) - 0.25


#: The torus's box: x <= 0.7 cuts its tube once.
TORUS_BOX = ((-1.0, -1.0, -0.5), (0.7, 1.0, 0.5))
