"""The damped Newton step shared by every Newton search in rdmesh.

Each search (critical points, probes projected onto the surface, singular
points, loops inside Voronoi facets) builds its own raw step from its own
equations; this module caps the step's length, so that no start jumps to a
far solution that belongs to another part of the surface.
"""

from __future__ import annotations

import numpy as np


def damped_step(
    x: np.ndarray, step: np.ndarray, cap: float | np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Move each point by its Newton step, shortened to at most ``cap``.

    Parameters
    ----------
    x : (n, 3) current points.
    step : (n, 3) raw Newton steps.
    cap : float or (n,) largest step length allowed.

    Returns
    -------
    x_new : (n, 3) the moved points.
    length : (n,) the raw steps' lengths (a convergence measure).
    """
    length = np.linalg.norm(step, axis=1)
    # Only steps longer than the cap are shortened (cap / TINY overflowed at R = 1e10).
    long = length > cap
    scale = np.ones(len(length))
    scale[long] = np.broadcast_to(cap, length.shape)[long] / length[long]
    return x + step * scale[:, None], length
