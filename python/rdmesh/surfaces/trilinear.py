"""Singular points of a trilinear interpolant's isosurface, and a regular isovalue (issue 30).

The trilinear interpolant is smooth inside each cell, with kinks across the
cell faces (its gradient jumps there), which refinement copes with. Its
isosurface is *singular* (not a surface: two sheets pinch to a point) where
the isovalue equals the value at a saddle of the interpolant: a face saddle
(the bilinear restriction to a cell face) or a body saddle (inside a cell).
A binary mask at its default isovalue 0.5 has one on every face whose
corners alternate 1, 0, 1, 0: there ``v = 0.5 + 2 (s - 1/2)(t - 1/2)``. No
sampling resolves such a point, so refinement runs into the spacing floor
there and the mesh is not closed.

:func:`regular_isovalue` moves the isovalue off these values by a small
amount, towards a smaller inside (a pinch point has ``f = 0``, which counts
as outside, so the inside's components are those of the open set
``{v > isovalue}``); near a saddle the two sheets are then about
``2 sqrt(delta / k)`` apart (``k`` the saddle's curvature), which the
refinement resolves.
"""

from __future__ import annotations

import numpy as np

#: Saddle values nearer the isovalue than this (times the data range) are singular.
SINGULAR_WINDOW = 1e-3
#: The isovalue moves by at most this (times the data range).
MAX_SHIFT = 1e-2
#: Candidate isovalues: multiples of MAX_SHIFT / CANDIDATES, in blocks of this many.
CANDIDATES = 64


def saddle_values(volume: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Values of the trilinear interpolant at its face and body saddles in
    the cells whose samples reach ``[lo, hi]``, ``(k,)``.

    Parameters
    ----------
    volume : (n0, n1, n2) float64
    lo, hi : float
        Only cells whose sample range meets ``[lo, hi]`` are searched.
    """
    v = volume
    c = [v[i : v.shape[0] - 1 + i, j : v.shape[1] - 1 + j, k : v.shape[2] - 1 + k]
         for i in (0, 1) for j in (0, 1) for k in (0, 1)]  # fmt: skip
    cmin = np.minimum.reduce(c)
    cmax = np.maximum.reduce(c)
    cells = np.nonzero((cmax >= lo) & (cmin <= hi))
    v000, v001, v010, v011, v100, v101, v110, v111 = (x[cells] for x in c)
    out = []
    # Faces: the six faces of each cell (shared faces twice; harmless).
    for a, b, cc, d in (
        (v000, v010, v001, v011), (v100, v110, v101, v111),  # x = 0, 1
        (v000, v100, v001, v101), (v010, v110, v011, v111),  # y = 0, 1
        (v000, v100, v010, v110), (v001, v101, v011, v111),  # z = 0, 1
    ):  # fmt: skip
        den = a - b - cc + d
        ok = den != 0
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (a - cc) / den
            t = (a - b) / den
            val = (a * d - b * cc) / den
        ok &= (s > 0) & (s < 1) & (t > 0) & (t < 1)
        out.append(val[ok])
    out.append(body_saddles(v000, v001, v010, v011, v100, v101, v110, v111)[1])
    return np.concatenate(out)


def regular_isovalue(volume: np.ndarray, isovalue: float, inside: str) -> float:
    """The isovalue, moved off the interpolant's saddle values if one is near.

    Parameters
    ----------
    volume : (n0, n1, n2) float64
    isovalue : float
    inside : {"greater", "less"}
        The shift makes the inside smaller: up for "greater", down for "less".

    Returns
    -------
    float
        ``isovalue`` itself when no saddle value is within
        :data:`SINGULAR_WINDOW` of it (times the data range). Otherwise the
        candidate farthest from every saddle value (distances capped at
        :data:`MAX_SHIFT`; ties to the smaller shift), among ``isovalue`` and
        the multiples of ``MAX_SHIFT / CANDIDATES`` (times the range) beyond it
        on the inside's shrinking side, in its block of :data:`CANDIDATES` of
        them: so it moves by less than ``MAX_SHIFT``, and passing the result
        back returns it unchanged (its candidates are some of the first
        call's, and the distances the same).
    """
    span = float(volume.max() - volume.min())
    window = SINGULAR_WINDOW * span
    direction = 1.0 if inside == "greater" else -1.0
    reach = MAX_SHIFT * span
    # Every saddle value within reach of every candidate (all within reach beyond).
    lo, hi = sorted(
        (isovalue - direction * (reach + window), isovalue + direction * (2 * reach + window))
    )
    near = saddle_values(volume, lo, hi)
    if not len(near) or np.min(np.abs(near - isovalue)) >= window:
        return isovalue
    step = reach / CANDIDATES
    t = direction * isovalue / step
    if abs(t - np.round(t)) <= 1e-9 * max(1.0, abs(t)):
        t = float(np.round(t))  # a value returned before: its own multiple
    block = np.floor(t / CANDIDATES) * CANDIDATES
    j = np.arange(block, block + CANDIDATES)
    cand = np.r_[isovalue, direction * (j[j > t] * step)]
    inner = (cand > volume.min()) & (cand < volume.max())
    inner[0] = True
    cand = cand[inner]
    gap = np.minimum(np.min(np.abs(cand[:, None] - near[None, :]), axis=1), reach)
    return float(cand[int(np.argmax(gap))])


def body_saddles(*corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Critical points inside cells of the trilinear interpolant.

    Parameters
    ----------
    corners : 8 arrays (m,)
        The corner values ``v000, v001, v010, v011, v100, v101, v110, v111``
        (index bits x, y, z) of ``m`` cells.

    Returns
    -------
    points : (k, 3) cell coordinates in (0, 1)^3 of the critical points
    values : (k,) the interpolant there

    Notes
    -----
    With ``f = a + b x + c y + d z + e xy + f xz + g yz + h xyz`` and
    ``h != 0``, the gradient vanishes where ``YZ = -B/h``, ``XZ = -C/h``,
    ``XY = -D/h`` (``X = x + g/h``, ``Y = y + f/h``, ``Z = z + e/h``,
    ``B = b - ef/h``, ``C = c - eg/h``, ``D = d - fg/h``), so
    ``(XYZ)^2 = -BCD/h^3``: two solutions at most.
    """
    v000, v001, v010, v011, v100, v101, v110, v111 = corners
    A = v000
    B = v100 - v000
    C = v010 - v000
    D = v001 - v000
    E = v110 - v100 - v010 + v000
    F = v101 - v100 - v001 + v000
    G = v011 - v010 - v001 + v000
    H = v111 - v110 - v101 - v011 + v100 + v010 + v001 - v000
    points, values = [], []
    with np.errstate(divide="ignore", invalid="ignore"):
        bb = B - E * F / H
        cq = C - E * G / H
        dd = D - F * G / H
        p2 = -bb * cq * dd / H**3
        for sign in (1.0, -1.0):
            p = sign * np.sqrt(p2)
            x = p / (-bb / H) - G / H
            y = p / (-cq / H) - F / H
            z = p / (-dd / H) - E / H
            val = A + B * x + C * y + D * z + E * x * y + F * x * z + G * y * z + H * x * y * z
            ok = (H != 0) & (p2 > 0) & np.isfinite(val)
            ok &= (x > 0) & (x < 1) & (y > 0) & (y < 1) & (z > 0) & (z < 1)
            points.append(np.column_stack([x[ok], y[ok], z[ok]]))
            values.append(val[ok])
    return np.concatenate(points), np.concatenate(values)
