"""Volumes of known topology for the volume tests and ``benchmarks/volume.py``.

- :func:`sample` samples a built-in surface's ``-f`` on a grid, so the
  isosurface at 0 (inside "greater") has the built-in surface's topology.
- :func:`phantom` is a small CT-like phantom: air, a soft-tissue body and three
  "bones" (a ring, a bar with knobs at its ends, a small ball), blurred and
  with noise. Its bone isosurface has 3 components of genus 1, 0 and 0.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

#: CT-like values (Hounsfield units) of the phantom.
AIR, TISSUE, BONE = -1000.0, 40.0, 1000.0
#: The phantom's bone threshold, and the Euler characteristics of its bones
#: (largest component first in rdmesh's order is not guaranteed: compare sorted).
BONE_ISOVALUE = 300.0
PHANTOM_EULER = [0, 2, 2]


def grid(shape: tuple[int, int, int], spacing, origin) -> np.ndarray:
    """World coordinates of the samples, ``shape + (3,)``: ``origin + index * spacing``."""
    axes = [o + s * np.arange(n) for n, s, o in zip(shape, spacing, origin, strict=True)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)


def sample(surface, lo, hi, n: int = 40) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``-f`` of ``surface`` on an ``n``-per-axis grid over the box ``[lo, hi]``.

    Returns ``(volume, spacing, origin)``; the isosurface ``volume = 0``
    (inside "greater") approximates the surface.
    """
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    spacing = (hi - lo) / (n - 1)
    pts = grid((n, n, n), spacing, lo)
    return -surface(pts.reshape(-1, 3)).reshape(n, n, n), spacing, lo


def _capsule(p: np.ndarray, a, b, radius: float) -> np.ndarray:
    """Signed distance to the capsule of ``radius`` around the segment a-b."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    ab = b - a
    t = np.clip(((p - a) @ ab) / (ab @ ab), 0.0, 1.0)
    return np.linalg.norm(p - a - t[..., None] * ab, axis=-1) - radius


def phantom(
    shape: tuple[int, int, int] = (48, 48, 32),
    spacing=(1.0, 1.0, 1.5),
    noise: float = 20.0,
    blur: float = 1.0,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """A small synthetic CT volume: ``(volume float32, spacing)``, origin 0.

    A soft-tissue ellipsoid in air holds three bones: a ring (torus), a bar
    with a knob at each end, and a small ball. The volume is blurred by a
    Gaussian of ``blur`` samples and gets Gaussian noise of ``noise`` HU
    (seeded). The bone isosurface (:data:`BONE_ISOVALUE`) has three
    components, Euler characteristics :data:`PHANTOM_EULER`.
    """
    spacing = np.asarray(spacing, dtype=float)
    p = grid(shape, spacing, (0.0, 0.0, 0.0))
    size = (np.asarray(shape) - 1) * spacing
    c = size / 2
    q = (p - c) / (0.45 * size)
    vol = np.where(np.einsum("...i,...i->...", q, q) < 1.0, TISSUE, AIR)
    s = size / 48.0 * 1.0  # lengths below are for a 48-unit box
    # A ring about the z axis, in the left half.
    ring_c = c + np.array([-10.0, -6.0, 0.0]) * s
    r = p - ring_c
    ring = np.hypot(np.hypot(r[..., 0], r[..., 1]) - 6.0 * s[0], r[..., 2]) - 2.2 * s[0]
    # A bar with knobs, in the right half.
    a = c + np.array([8.0, -12.0, -3.0]) * s
    b = c + np.array([10.0, 12.0, 3.0]) * s
    bar = np.minimum(
        _capsule(p, a, b, 2.0 * s[0]),
        np.minimum(
            np.linalg.norm(p - a, axis=-1) - 3.5 * s[0],
            np.linalg.norm(p - b, axis=-1) - 3.5 * s[0],
        ),
    )
    # A small ball.
    ball = np.linalg.norm(p - (c + np.array([-8.0, 12.0, 0.0]) * s), axis=-1) - 3.0 * s[0]
    bone = np.minimum(np.minimum(ring, bar), ball) < 0
    vol = np.where(bone, BONE, vol)
    vol = ndimage.gaussian_filter(vol, blur / np.asarray(spacing) * spacing.min(), mode="nearest")
    rng = np.random.default_rng(seed)
    vol = vol + rng.normal(0.0, noise, size=vol.shape)
    return vol.astype(np.float32), spacing


def kinked_lens() -> np.ndarray:
    """A 25^3 linear-interpolation test volume (isovalue 0): a lens whose rim
    lies on the grid plane x = 12, a kink that needs edge and vertex repairs
    late in the run (few touched samples each)."""
    i = np.arange(25, dtype=float)
    x, y, z = np.meshgrid(i, i, i, indexing="ij")
    return 1.0 - np.abs(x - 12.0) - 0.01 * ((y - 12.0) ** 2 + (z - 12.0) ** 2)
