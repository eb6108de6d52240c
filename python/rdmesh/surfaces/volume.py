"""Isosurfaces of sampled 3-D volumes (CT, MRI, simulation grids) as implicit surfaces.

:class:`VolumeSurface` interpolates a volume (a cubic B-spline by default,
trilinear on request) and closes the isosurface by the faces of the volume's
box, so :func:`rdmesh.mesh_surface` can mesh it like any other
:class:`~rdmesh.ImplicitSurface`.

Conventions are those of :func:`skimage.measure.marching_cubes`: the axis
order of the array is the coordinate order of the points, and sample
``volume[i, j, k]`` sits at ``origin + (i, j, k) * spacing``.
"""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np
from scipy import ndimage

from .._errors import EmptySurfaceError
from .._validate import choice
from ..core import VolumeSampler
from ._volume_oracle import VolumeOracle
from .oracle import ImplicitSurface
from .trilinear import regular_isovalue

log = logging.getLogger("rdmesh")

INSIDE = ("greater", "less")
INTERPOLATIONS = ("cubic", "linear")
BORDERS = ("closed", "clipped")
#: The B-spline degree of each interpolation, and the sign of ``f`` for each inside.
DEGREES = {"cubic": 3, "linear": 1}
SIGNS = {"greater": 1.0, "less": -1.0}

#: Smallest number of samples per axis for each interpolation.
MIN_SAMPLES = {"cubic": 4, "linear": 2}
#: The bounding sphere is the sphere about the box, enlarged by this factor.
SPHERE_MARGIN = 1.1


def _taps(
    x: np.ndarray, n: int, degree: int, derivative: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Sample indices and B-spline weights along one axis.

    Parameters
    ----------
    x : (N,) float
        Continuous sample coordinates, already clamped to ``[0, n - 1]``.
    n : int
        Samples along the axis.
    degree : {1, 3}
        Linear or cubic B-spline.
    derivative : bool
        Also return the weights of the derivative.

    Returns
    -------
    index : (N, degree + 1) int64
        The samples (coefficients) each point uses, mirrored at the ends as
        scipy.ndimage's ``mode="mirror"`` does.
    weight, dweight : (N, degree + 1) float64
        Weights of the value and (if asked) of its derivative along the axis.
    """
    i0 = np.minimum(np.floor(x), n - 2).astype(np.int64)
    t = (x - i0)[:, None]
    if degree == 1:
        index = i0[:, None] + np.arange(2)
        weight = np.concatenate([1.0 - t, t], axis=1)
        dweight = np.tile([-1.0, 1.0], (len(x), 1)) if derivative else None
        return index, weight, dweight
    index = np.abs(i0[:, None] + np.arange(-1, 3))
    index = np.where(index > n - 1, 2 * (n - 1) - index, index)
    t2 = t * t
    t3 = t2 * t
    s = 1.0 - t
    weight = np.concatenate(
        [s * s * s, 3 * t3 - 6 * t2 + 4, -3 * t3 + 3 * t2 + 3 * t + 1, t3], axis=1
    ) * (1.0 / 6.0)
    dweight = None
    if derivative:
        dweight = np.concatenate(
            [-0.5 * s * s, 1.5 * t2 - 2 * t, -1.5 * t2 + t + 0.5, 0.5 * t2], axis=1
        )
    return index, weight, dweight


def tensor_spline(
    coefficients: np.ndarray, coords: np.ndarray, degree: int, gradient: bool = False
) -> tuple[np.ndarray, np.ndarray | None]:
    """Evaluate a tensor-product B-spline and, optionally, its exact gradient.

    Parameters
    ----------
    coefficients : (n0, n1, n2) float64, C-contiguous
        B-spline coefficients (for ``degree=3``, the output of
        ``scipy.ndimage.spline_filter(..., order=3, mode="mirror")``; for
        ``degree=1``, the samples themselves).
    coords : (N, 3) float64
        Continuous sample coordinates; clamped to the grid.
    degree : {1, 3}
    gradient : bool
        Also return the gradient with respect to the sample coordinates.

    Returns
    -------
    values : (N,) float64
    gradient : (N, 3) float64 or None

    Notes
    -----
    Gathers ``(degree + 1)**3`` coefficients per point (64 for cubic) and
    contracts them axis by axis, so the value and the three derivatives share
    one gather. Equals ``scipy.ndimage.map_coordinates(coefficients, coords.T,
    order=degree, mode="mirror", prefilter=False)`` inside the grid.
    """
    shape = coefficients.shape
    k = degree + 1
    x = np.clip(coords, 0.0, np.asarray(shape, dtype=np.float64) - 1.0)
    (ix, wx, dx), (iy, wy, dy), (iz, wz, dz) = (
        _taps(x[:, a], shape[a], degree, gradient) for a in range(3)
    )
    rows, cols = shape[1] * shape[2], shape[2]
    flat = ix[:, :, None, None] * rows + iy[:, None, :, None] * cols + iz[:, None, None, :]
    c = coefficients.ravel()[flat.reshape(len(x), -1)].reshape(len(x), k, k, k)
    # Contract z, then y, then x; each partial is shared by the value and the derivatives.
    a = np.einsum("nijk,nk->nij", c, wz)
    b = np.einsum("nij,nj->ni", a, wy)
    values = np.einsum("ni,ni->n", b, wx)
    if not gradient:
        return values, None
    az = np.einsum("nijk,nk->nij", c, dz)
    g = np.empty((len(x), 3))
    g[:, 0] = np.einsum("ni,ni->n", b, dx)
    g[:, 1] = np.einsum("nij,nj,ni->n", a, dy, wx)
    g[:, 2] = np.einsum("nij,nj,ni->n", az, wy, wx)
    return values, g


def _three(name: str, value: Any, positive: bool) -> np.ndarray:
    """``value`` as 3 finite float64 numbers (positive ones if asked)."""
    try:
        v = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        v = np.full(0, np.nan)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or (positive and np.any(v <= 0)):
        what = "3 positive finite numbers" if positive else "3 finite numbers"
        raise ValueError(f"{name} must be {what}, one per volume axis, got {value!r}")
    return v


def _volume(volume: Any, interpolation: str) -> np.ndarray:
    """The volume as a C-contiguous float64 array, after checking it."""
    arr = np.asarray(volume)
    if arr.dtype == np.bool_:
        arr = arr.astype(np.float64)
    elif not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
        raise ValueError(
            f"volume must hold real numbers (integers, floats or booleans), got dtype {arr.dtype}"
        )
    if arr.ndim != 3:
        raise ValueError(f"volume must be a 3-D array, got {arr.ndim}-D with shape {arr.shape}")
    least = MIN_SAMPLES[interpolation]
    if min(arr.shape) < least:
        raise ValueError(
            f"volume must have at least {least} samples along each axis for "
            f"{interpolation} interpolation, got shape {arr.shape}"
        )
    arr = np.ascontiguousarray(arr, dtype=np.float64)
    bad = ~np.isfinite(arr)
    if bad.any():
        where = np.unravel_index(int(np.argmax(bad)), arr.shape)
        raise ValueError(
            f"volume must be finite: {int(bad.sum())} NaN or infinite samples, the first "
            f"at index {tuple(int(i) for i in where)}"
        )
    return arr


def _gradient_scale(volume: np.ndarray, isovalue: float, spacing: np.ndarray) -> float:
    """Median |difference / spacing| over the grid edges the isosurface crosses.

    Dividing ``isovalue - v`` by it makes ``f`` about a signed distance near
    the surface, so it is commensurate with the distance to the box.
    """
    above = volume > isovalue
    slopes = []
    for axis in range(3):
        first = [slice(None)] * 3
        second = [slice(None)] * 3
        first[axis], second[axis] = slice(None, -1), slice(1, None)
        a, b = tuple(first), tuple(second)
        cross = above[a] != above[b]  # one end above the isovalue, the other not
        slopes.append(np.abs(volume[b][cross] - volume[a][cross]) / spacing[axis])
    s = np.concatenate(slopes)
    return float(np.median(s)) if len(s) else 1.0


class VolumeSurface(VolumeOracle, ImplicitSurface):
    """The isosurface ``v = isovalue`` of an interpolated 3-D volume, closed by its box.

    Parameters
    ----------
    volume : (n0, n1, n2) array_like of real numbers
        The samples. Integers and floats of any width are converted to
        float64; booleans (masks) become 0 and 1, so the default isovalue is
        0.5 (a mask gives a staircase-like surface: blur it first for a smooth
        one). Complex and other types raise ValueError.
    spacing : 3 positive floats, default (1, 1, 1)
        Distance between samples along each array axis.
    origin : 3 floats, default (0, 0, 0)
        Position of ``volume[0, 0, 0]``. Sample ``volume[i, j, k]`` sits at
        ``origin + (i, j, k) * spacing``, as for
        :func:`skimage.measure.marching_cubes` (whose vertices are
        ``index * spacing``, without the origin).
    isovalue : float, optional
        The level to mesh; default the midpoint ``(min + max) / 2`` of the
        data, as in marching_cubes. Must lie strictly between the smallest and
        the largest sample.
    inside : {"greater", "less"}, default "greater"
        Which side is inside: "greater" (values above the isovalue, such as
        bone in CT) gives ``f = (isovalue - v) / value_scale``; "less" the
        opposite sign. ``(volume, inside="greater")`` and ``(-volume,
        isovalue=-isovalue, inside="less")`` are the same surface. On one
        volume, "greater" and "less" give the same isosurface with opposite
        orientations only where it does not reach the box: each is closed by
        the box on its own side.
    interpolation : {"cubic", "linear"}, default "cubic"
        "cubic": the cubic B-spline interpolating the samples (prefiltered
        once with ``scipy.ndimage.spline_filter``, mirror boundary), twice
        continuously differentiable, with its exact gradient. "linear":
        trilinear interpolation, as CGAL's gray-level images; continuous, its
        gradient jumps across voxel faces.
    border : {"closed", "clipped"}, default "closed"
        How the isosurface ends at the faces of the box: "closed" closes it
        by the faces, as if everything outside the box were outside, so the
        mesh is watertight. "clipped" cuts it there: ``f`` is the volume's
        alone, ``clip_box`` is the box, and :func:`rdmesh.mesh_surface`
        meshes the part inside the box with
        ``topology="manifold-with-boundary"`` (its default for such a
        surface; other topologies, the topological-ball method and certify
        raise ValueError). The boundary follows the curve where the
        isosurface meets the faces, with a vertex where it crosses a box
        edge (see the README, "Volumes").
    name : str, default "volume"
        A label for logs and reports.
    features : list of (m, 3) array_like, or "none", optional
        Feature curves to keep (see :class:`rdmesh.ImplicitSurface`). With
        ``border="closed"`` the curves where the isosurface meets the box
        faces, and the box edges and corners inside the region, are
        protected as well; for "linear" (either border) so are the sharp
        kinks on the grid planes. "none" protects nothing (creases are cut).

    Attributes
    ----------
    isovalue : float
        The level meshed: the one asked for, except with linear interpolation
        near a saddle value of the trilinear interpolant (where it pinches):
        then, with a warning, a value within 1 % of the data range towards a
        smaller inside, far from saddle values (on dense data still near
        one); passed back as ``isovalue``, it is kept.
    requested_isovalue : float
        The isovalue asked for (or the default).
    value_scale : float
        The median data slope (value per unit length) across the isosurface
        along the grid edges; ``f`` is divided by it, so near the surface ``f``
        is about the signed distance.
    box : (2, 3) float64
        The lowest and highest corners of the box of the samples.
    shape, spacing, origin, inside, interpolation, border
        As given (checked).

    Raises
    ------
    ValueError
        A volume that is not 3-D, has too few samples along an axis (2 for
        linear, 4 for cubic), holds NaN or infinity or non-real numbers; a
        spacing or origin that is not 3 finite numbers (spacing: positive);
        an unknown option.
    rdmesh.EmptySurfaceError
        (a ValueError) a constant volume, or an isovalue outside the open
        range of the data: there is no surface.

    Notes
    -----
    With ``border="closed"``, ``f`` is ``max(f_volume, d_box)``: ``f_volume`` is the interpolated
    ``(isovalue - v) / value_scale`` (sign per ``inside``), ``d_box`` the
    signed distance to the box (negative inside). It is positive outside the
    box, so on and outside the bounding sphere (the sphere about the box,
    enlarged by 10%). Inside the box, away from its faces, the mesh is a mesh
    of the interpolant's isosurface, and rdmesh's guarantees apply to that
    smooth surface (for "linear", which is not smooth, the topology
    guarantees do not hold; the angle and size bounds still do).
    Where the isosurface meets a face of the box, the closed surface has a
    crease (a sharp edge), where those guarantees do not hold; the crease
    (traced on the box faces, sampled) and the box edges inside the region
    are protected by balls, so the mesh's edges follow them and
    ``SurfaceMesh.features`` reports whether every one was kept (with
    ``features="none"``, or the topological-ball method, the crease is cut
    by triangles instead). The
    cubic interpolant's mirror boundary makes its normal derivative vanish on
    the faces, so its isosurface meets the faces at right angles.

    As for any surface, components narrower than about 1.7 cells of
    :func:`rdmesh.mesh_surface`'s seeding grid (``seed_resolution`` cells
    across the bounding ball, 64 by default: a cell is about ``n / 34``
    samples for a cube of ``n`` samples a side) may be missed; raise
    ``seed_resolution`` for volumes with small separate parts.

    Values and exact gradients come from a compiled tensor-product sampler
    (``rdmesh.core.VolumeSampler``, 64 coefficients per point for cubic, the
    GIL released). It measured faster than ``scipy.ndimage.map_coordinates``
    (which gives values only) and gives the gradient in the same pass; in a
    meshing run the oracle's time fell to about a third
    (``benchmarks/volume_sampler.py``). :func:`tensor_spline` is the same
    evaluator in numpy, the reference the tests compare with. Memory: the
    sampler holds one float64 coefficient per sample (8 bytes per voxel).
    """

    def __init__(
        self, volume: Any, *, spacing: Any = (1.0, 1.0, 1.0), origin: Any = (0.0, 0.0, 0.0),
        isovalue: float | None = None, inside: str = "greater", interpolation: str = "cubic",
        border: str = "closed", name: str = "volume", features: Any = None,
    ) -> None:  # fmt: skip
        self.inside, self.interpolation, self.border = _options(inside, interpolation, border)
        data, self.spacing, self.origin = _samples(volume, spacing, origin, interpolation)
        #: The isovalue asked for; ``isovalue`` is the one meshed (linear: off saddle values).
        self.requested_isovalue, self.isovalue = _isovalues(data, isovalue, interpolation, inside)
        self.shape, self.degree, self._sign = data.shape, DEGREES[interpolation], SIGNS[inside]
        self.value_scale = _gradient_scale(data, self.isovalue, self.spacing)
        data = _coefficients(data, self.degree)  # the samples are dropped here
        self._sampler = VolumeSampler(data, self.degree, self.origin, self.spacing)
        del data  # the sampler keeps its own copy of the coefficients
        self.box, ball = _box_and_sphere(self.shape, self.origin, self.spacing)
        log.debug(
            "volume %s, spacing %s, isovalue %g, %s interpolation, value scale %g",
            self.shape, self.spacing.tolist(), self.isovalue, interpolation, self.value_scale,
        )  # fmt: skip
        f, grad, clip_box = self._border_oracle()
        super().__init__(f, ball, gradient=grad, name=name, clip_box=clip_box, features=features)

    def __repr__(self) -> str:
        return (
            f"VolumeSurface(shape={self.shape}, spacing={tuple(self.spacing.tolist())}, "
            f"origin={tuple(self.origin.tolist())}, isovalue={self.isovalue:g}, "
            f"inside={self.inside!r}, interpolation={self.interpolation!r}, "
            f"border={self.border!r})"
        )


def _options(inside: str, interpolation: str, border: str) -> tuple[str, str, str]:
    """``inside``, ``interpolation`` and ``border``, checked.

    Raises
    ------
    ValueError
        An unknown option (the message lists the known ones).
    """
    choice("inside", inside, INSIDE)
    choice("interpolation", interpolation, INTERPOLATIONS)
    choice("border", border, BORDERS)
    return inside, interpolation, border


def _samples(
    volume: Any, spacing: Any, origin: Any, interpolation: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The volume (C-contiguous float64), the spacing and the origin, checked.

    Raises
    ------
    ValueError
        A bad volume, spacing or origin (see :class:`VolumeSurface`).
    """
    data = _volume(volume, interpolation)
    spacing = _three("spacing", spacing, positive=True)
    return data, spacing, _three("origin", origin, positive=False)


def _isovalues(
    data: np.ndarray, isovalue: float | None, interpolation: str, inside: str
) -> tuple[float, float]:
    """The isovalue asked for (default the middle of the data's range) and the one meshed.

    With linear interpolation the one meshed is moved off the trilinear
    interpolant's saddle values (:func:`~rdmesh.surfaces.trilinear.regular_isovalue`),
    with a warning; otherwise it is the one asked for.

    Raises
    ------
    ValueError
        An isovalue that is not a finite number.
    rdmesh.EmptySurfaceError
        A constant volume, or an isovalue outside the open range of the data.
    """
    lo, hi = float(data.min()), float(data.max())
    if lo == hi:
        raise EmptySurfaceError(f"the volume is constant ({lo:g}): it has no isosurface")
    if isovalue is None:
        isovalue = 0.5 * (lo + hi)
    try:
        iso = float(isovalue)
    except (TypeError, ValueError):
        raise ValueError(f"isovalue must be a number, got {isovalue!r}") from None
    if not math.isfinite(iso):
        raise ValueError(f"isovalue must be finite, got {isovalue!r}")
    if not lo < iso < hi:
        raise EmptySurfaceError(
            f"isovalue {iso:g} is outside the range of the volume's data, "
            f"({lo:g}, {hi:g}): there is no isosurface"
        )
    requested = iso
    if interpolation == "linear":
        iso = regular_isovalue(data, iso, inside)
        if iso != requested:
            log.warning(
                "isovalue %g is a saddle value of the trilinear interpolant (its "
                "isosurface pinches to a point there): meshing %g instead",
                requested,
                iso,
            )
    return requested, iso


def _coefficients(data: np.ndarray, degree: int) -> np.ndarray:
    """The B-spline coefficients of ``degree`` through the samples ``data``: for cubic,
    prefiltered with ``scipy.ndimage.spline_filter`` (mirror boundary); for linear,
    the samples themselves."""
    if degree == 3:
        return ndimage.spline_filter(data, order=3, mode="mirror", output=np.float64)
    return data


def _box_and_sphere(
    shape: tuple[int, ...], origin: np.ndarray, spacing: np.ndarray
) -> tuple[np.ndarray, tuple[np.ndarray, float]]:
    """The box of the samples, ``(2, 3)``, and the bounding sphere ``(centre, radius)``:
    the sphere about the box, enlarged by ``SPHERE_MARGIN``."""
    extent = (np.asarray(shape) - 1) * spacing
    box = np.array([origin, origin + extent])
    centre = 0.5 * (box[0] + box[1])
    radius = SPHERE_MARGIN * 0.5 * float(np.linalg.norm(extent))
    return box, (centre, radius)
