"""Built-in test surfaces (algorithm.md, section 6), each with an exact gradient.

Every function returns a fresh :class:`~rdmesh.ImplicitSurface`; ``f < 0`` inside.
``SURFACES`` maps names to those functions and to the topology each surface has.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .oracle import ImplicitSurface


def _xyz(p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return p[:, 0], p[:, 1], p[:, 2]


def sphere(radius: float = 1.0) -> ImplicitSurface:
    """Sphere of the given radius about the origin."""

    def f(p):
        x, y, z = _xyz(p)
        return x * x + y * y + z * z - radius**2

    return ImplicitSurface(f, ((0, 0, 0), 2.0 * radius), gradient=lambda p: 2 * p, name="sphere")


def ellipsoid(a: float = 1.5, b: float = 1.0, c: float = 0.5) -> ImplicitSurface:
    """Ellipsoid with semi-axes a, b, c (lfs_min = 1/6 for the defaults)."""
    s = np.array([a, b, c]) ** -2.0

    def f(p):
        x, y, z = _xyz(p)
        return s[0] * (x * x) + s[1] * (y * y) + s[2] * (z * z) - 1.0

    def grad(p):
        x, y, z = _xyz(p)
        return np.column_stack([2.0 * s[0] * x, 2.0 * s[1] * y, 2.0 * s[2] * z])

    return ImplicitSurface(f, ((0, 0, 0), max(a, b, c) + 0.5), gradient=grad, name="ellipsoid")


def torus(major: float = 1.0, minor: float = 0.4, bound: float | None = None) -> ImplicitSurface:
    """Torus about the z axis: ``(|p|^2 + R^2 - r^2)^2 - 4 R^2 (x^2 + y^2)``."""
    R2, r2 = major**2, minor**2

    def f(p):
        x, y, z = _xyz(p)
        q = x * x + y * y
        s = q + z * z + R2 - r2
        return s * s - 4.0 * R2 * q

    def grad(p):
        x, y, z = _xyz(p)
        s = x * x + y * y + z * z + R2 - r2
        gx = 4.0 * x * s - 8.0 * R2 * x
        gy = 4.0 * y * s - 8.0 * R2 * y
        return np.column_stack([gx, gy, 4.0 * z * s])

    name = "torus" if minor >= 0.2 * major else "thin torus"
    radius = bound if bound is not None else 2.0 * major
    return ImplicitSurface(f, ((0, 0, 0), radius), gradient=grad, name=name)


def thin_torus() -> ImplicitSurface:
    """Torus with R = 1, r = 0.1 (small lfs)."""
    return torus(1.0, 0.1, bound=1.5)


def double_torus() -> ImplicitSurface:
    """Genus-2 surface (x(x-1)^2(x-2) + y^2)^2 + z^2 - 0.01."""

    def f(p):
        x, y, z = _xyz(p)
        u = x * (x - 1) ** 2 * (x - 2) + y * y
        return u * u + z * z - 0.01

    def grad(p):
        x, y, z = _xyz(p)
        u = x * (x - 1) ** 2 * (x - 2) + y * y
        du = (x - 1) ** 2 * (x - 2) + 2 * x * (x - 1) * (x - 2) + x * (x - 1) ** 2
        return np.column_stack([2 * u * du, 4 * u * y, 2 * z])

    return ImplicitSurface(f, ((1, 0, 0), 1.5), gradient=grad, name="double torus")


def tanglecube() -> ImplicitSurface:
    """Genus-5 tanglecube x^4 - 5x^2 + y^4 - 5y^2 + z^4 - 5z^2 + 11.8."""

    def f(p):
        x, y, z = _xyz(p)
        x2, y2, z2 = x * x, y * y, z * z
        return x2 * (x2 - 5.0) + y2 * (y2 - 5.0) + z2 * (z2 - 5.0) + 11.8

    def grad(p):
        return np.column_stack([v * (4.0 * v * v - 10.0) for v in _xyz(p)])

    return ImplicitSurface(f, ((0, 0, 0), 4.0), gradient=grad, name="tanglecube")


def two_spheres(gap: float = 0.1) -> ImplicitSurface:
    """Two unit spheres whose surfaces are ``gap`` apart (lfs = gap/2 there)."""
    c = 1.0 + gap / 2.0

    def parts(p):
        x, y, z = _xyz(p)
        q = y * y + z * z - 1.0
        return x, y, z, (x - c) * (x - c) + q, (x + c) * (x + c) + q

    def f(p):
        _, _, _, fa, fb = parts(p)
        return fa * fb

    def grad(p):
        x, y, z, fa, fb = parts(p)
        s = 2.0 * (fa + fb)
        return np.column_stack([2.0 * ((x - c) * fb + (x + c) * fa), s * y, s * z])

    return ImplicitSurface(f, ((0, 0, 0), c + 1.45), gradient=grad, name="two spheres")


def blob_line() -> ImplicitSurface:
    """Three merging Gaussian blobs along the x axis."""
    # 0.5 - sum_k exp(-|p - c_k|^2 / 0.25), c_k = (-0.9, 0, 0), (0, 0, 0), (0.9, 0, 0).
    # Column-wise: (N, 3, 3) temporaries made f four times slower.
    xs = (-0.9, 0.0, 0.9)

    def terms(p):
        x = p[:, 0]
        q = p[:, 1] * p[:, 1] + p[:, 2] * p[:, 2]
        return x, [np.exp(-4.0 * ((x - c) * (x - c) + q)) for c in xs]

    def f(p):
        _, e = terms(p)
        return 0.5 - (e[0] + e[1] + e[2])

    def grad(p):
        x, e = terms(p)
        total = e[0] + e[1] + e[2]
        gx = 8.0 * sum(ek * (x - c) for ek, c in zip(e, xs, strict=True))
        return np.column_stack([gx, 8.0 * total * p[:, 1], 8.0 * total * p[:, 2]])

    return ImplicitSurface(f, ((0, 0, 0), 2.0), gradient=grad, name="blob line")


@dataclass(frozen=True)
class SurfaceInfo:
    """A built-in surface: its constructor and its topology."""

    make: Callable[[], ImplicitSurface]
    components: int
    euler: int
    description: str


SURFACES: dict[str, SurfaceInfo] = {
    "sphere": SurfaceInfo(sphere, 1, 2, "unit sphere"),
    "ellipsoid": SurfaceInfo(ellipsoid, 1, 2, "ellipsoid 1.5 x 1 x 0.5"),
    "torus": SurfaceInfo(torus, 1, 0, "torus R=1, r=0.4"),
    "thin_torus": SurfaceInfo(thin_torus, 1, 0, "torus R=1, r=0.1"),
    "double_torus": SurfaceInfo(double_torus, 1, -2, "genus-2 surface"),
    "tanglecube": SurfaceInfo(tanglecube, 1, -8, "genus-5 tanglecube"),
    "two_spheres": SurfaceInfo(two_spheres, 2, 4, "two unit spheres 0.1 apart"),
    "blob_line": SurfaceInfo(blob_line, 1, 2, "three merging Gaussian blobs"),
}


#: Each built-in surface (default parameters) as an expression text, for
#: :func:`~rdmesh.surfaces.expressions.parse_expression`: the same function as
#: the numpy one, written so that its interval enclosures
#: (:mod:`rdmesh.surfaces.intervals`) are available. Constants are spelled as
#: the numpy functions compute them (``1 - 0.4**2``, not ``0.84``).
BUILTIN_EXPRESSIONS: dict[str, str] = {
    "sphere": "x**2 + y**2 + z**2 - 1",
    "ellipsoid": "x**2/1.5**2 + y**2 + z**2/0.5**2 - 1",
    "torus": "(x**2 + y**2 + z**2 + 1 - 0.4**2)**2 - 4*(x**2 + y**2)",
    "thin_torus": "(x**2 + y**2 + z**2 + 1 - 0.1**2)**2 - 4*(x**2 + y**2)",
    "double_torus": "(x*(x - 1)**2*(x - 2) + y**2)**2 + z**2 - 0.01",
    "tanglecube": "x**4 - 5*x**2 + y**4 - 5*y**2 + z**4 - 5*z**2 + 11.8",
    "two_spheres": "((x - 1.05)**2 + y**2 + z**2 - 1)*((x + 1.05)**2 + y**2 + z**2 - 1)",
    "blob_line": (
        "0.5 - exp(-4*((x + 0.9)**2 + y**2 + z**2)) - exp(-4*(x**2 + y**2 + z**2))"
        " - exp(-4*((x - 0.9)**2 + y**2 + z**2))"
    ),
}


def get(name: str) -> ImplicitSurface:
    """Return a new instance of the built-in surface ``name``.

    Raises
    ------
    ValueError
        If no built-in surface has that name.
    """
    key = name.strip().lower().replace("-", "_").replace(" ", "_")
    if key not in SURFACES:
        raise ValueError(f"unknown surface {name!r}; built-in surfaces: {', '.join(SURFACES)}")
    return SURFACES[key].make()
