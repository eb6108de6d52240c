# SPDX-License-Identifier: GPL-3.0-or-later
"""Volumes as suite rows: rdmesh.VolumeSurface (cubic) against CGAL's gray-image
Mesh_3 and marching cubes.

Cases (volumes of known topology, from ``tests/volumes.py``):

- ``torus volume``: the built-in torus's ``-f`` sampled on a grid (40^3 at
  scale 1);
- ``noisy torus volume``: the same with Gaussian noise, then blurred
  (40^3 at scale 1; ``benchmarks/volume.py`` uses scale 2, 80^3);
- ``CT phantom``: the small CT-like phantom (48x48x32 at scale 1; three
  bones, Euler characteristics 0, 2, 2).

A target vertex count sets the *scale* of the volume (samples per axis times
the scale, the same physical object; the phantom's blur in physical units,
the noisy torus's one sample), so
that marching cubes at the volume's own resolution gives about that many
vertices, never below the case's smallest scale (where its topology is
known); rdmesh meshes the same volume with radius bound = distance bound
``r = sqrt(0.7 area / size)``.

Meshers:

- ``rdmesh``: ``VolumeSurface`` (cubic B-spline, closed by the box);
- ``cgal_mesh_3_image``: CGAL's Mesh_3 on its gray-image domain
  (``Labeled_mesh_domain_3::create_gray_image_mesh_domain``, the reference
  program's ``mesh_3_image`` mode), what CT/MRI users mesh volumes with.
  The same volume (written as raw float32, not timed), isovalue and criteria
  as rdmesh, ``params::manifold()``, the suite's error bound. CGAL
  interpolates the samples trilinearly (its only interpolation for gray
  images), puts values above the isovalue inside (rdmesh's
  ``inside="greater"``) and everything outside the samples' box outside, so
  both mesh the same object up to the interpolation. Initial points are
  ``make_mesh_3``'s own (random segments through the domain's box, as CGAL's
  ``mesh_3D_gray_image`` example);
- ``cgal_mesh_3_image_components``: the same, seeded first with a point per
  connected component of the samples above the isovalue
  (``initialize_triangulation_from_gray_image``, then ``refine_mesh_3``, as
  CGAL's ``mesh_3D_gray_image_with_custom_initialization`` example): the
  random initial points can miss small components, such as the phantom's
  bones;
- ``marching_cubes``: ``skimage.measure.marching_cubes`` on the samples.

Quality: the suite's fields, the Hausdorff distance to the cubic interpolant
(``metrics.hausdorff``: reference points on it, Newton projection onto it;
CGAL and marching cubes mesh the trilinear one, so part of their distance is
the difference between the two interpolants), and the Euler characteristic
of each component against the known ones.
"""

from __future__ import annotations

import math
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache, lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from inputs import VERTICES_PER_AREA, InputKind, quality_entry
from meshers import Cgal, build_cgal
from meshfile import mesh_run

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import volumes  # noqa: E402

__all__ = ["CASES", "INPUT", "VolumeCase", "noisy_torus", "phantom", "torus"]

#: The box the tori are sampled over.
TORUS_BOX = ((-1.6, -1.6, -0.6), (1.6, 1.6, 0.6))
#: Marching cubes vertices per (area / spacing^2) (as ``meshers.py`` uses).
_MC_DENSITY = 1.5
#: The CGAL rows: mesher name -> how the reference program finds initial points.
CGAL_IMAGE = {"cgal_mesh_3_image": "random", "cgal_mesh_3_image_components": "components"}


def torus(scale: float = 1.0) -> tuple[np.ndarray, dict]:
    """The built-in torus sampled on ``round(40 scale)`` samples per axis.

    Returns ``(volume, VolumeSurface keywords)``.
    """
    import rdmesh

    n = round(40 * scale)
    vol, sp, org = volumes.sample(rdmesh.surfaces.torus(), *TORUS_BOX, n)
    return vol, {"spacing": sp, "origin": org, "isovalue": 0.0}


def noisy_torus(scale: float = 1.0) -> tuple[np.ndarray, dict]:
    """:func:`torus` plus Gaussian noise (0.02, seeded), blurred by one sample."""
    from scipy import ndimage

    vol, kw = torus(scale)
    rng = np.random.default_rng(4)
    vol = ndimage.gaussian_filter(vol + rng.normal(0, 0.02, vol.shape), 1.0)
    return vol, kw


def phantom(scale: float = 1.0) -> tuple[np.ndarray, dict]:
    """The CT-like phantom (``tests/volumes.py``) at ``scale`` times 48x48x32 samples.

    The same physical size (47 x 47 x 46.5) and blur (1 sample at scale 1).
    """
    base_shape = np.array([48, 48, 32])
    base_spacing = np.array([1.0, 1.0, 1.5])
    shape = np.round((base_shape - 1) * scale).astype(int) + 1
    spacing = base_spacing * (base_shape - 1) / (shape - 1)
    vol, sp = volumes.phantom(
        tuple(int(s) for s in shape), spacing, blur=base_spacing.min() / spacing.min()
    )
    return vol, {"spacing": sp, "isovalue": volumes.BONE_ISOVALUE}


@dataclass(frozen=True)
class VolumeCase:
    """A volume of known topology: its builder, Euler characteristic per
    component and the smallest scale at which that topology is sure."""

    build: Callable[[float], tuple[np.ndarray, dict]]
    euler: tuple[int, ...]
    min_scale: float


CASES = {
    "torus volume": VolumeCase(torus, (0,), 0.6),
    "noisy torus volume": VolumeCase(noisy_torus, (0,), 0.6),
    "CT phantom": VolumeCase(phantom, tuple(volumes.PHANTOM_EULER), 1.0),
}


def _marching_cubes(vol: np.ndarray, kw: dict, origin) -> tuple[np.ndarray, np.ndarray]:
    """skimage's marching cubes of the volume, outward, in world coordinates."""
    from skimage.measure import marching_cubes

    v, f, _, _ = marching_cubes(vol, kw["isovalue"], spacing=tuple(kw["spacing"]))
    # skimage orients towards greater values (inside here); rdmesh outward.
    return v + np.asarray(origin, float), f[:, ::-1].astype(np.int64)


@cache
def _base(case: str) -> tuple[int, float]:
    """(marching cubes vertices, isosurface area) of ``case`` at scale 1."""
    from metrics import mesh_area

    vol, kw = CASES[case].build(1.0)
    v, f = _marching_cubes(vol, kw, kw.get("origin", (0, 0, 0)))
    return len(v), mesh_area(v, f)


@cache
def _surface(case: str, scale: float):
    """(volume, keywords, cubic VolumeSurface) of ``case`` at ``scale``."""
    import rdmesh

    vol, kw = CASES[case].build(scale)
    return vol, kw, rdmesh.VolumeSurface(vol, **kw)


class CgalImage(Cgal):
    """CGAL's Mesh_3 on the gray-image domain of a case's volume.

    The volume goes to the program as a raw float32 file, written (once per
    case and scale, not timed) to a directory removed with the adapter.
    """

    def __init__(self, name: str, exe: Path | None) -> None:
        super().__init__(name, exe)
        self.init = CGAL_IMAGE[name]
        self._dir = tempfile.TemporaryDirectory(prefix="rdmesh-volume-")
        self._files: dict[tuple[str, float], Path] = {}

    def volume_file(self, case: str, scale: float) -> Path:
        """The raw file of ``case`` at ``scale`` (written on first use)."""
        from cgal_runner import write_volume

        key = (case, scale)
        if key not in self._files:
            vol, _, _ = _surface(case, scale)
            path = Path(self._dir.name) / f"volume-{len(self._files)}.f32"
            write_volume(path, vol)
            self._files[key] = path
        return self._files[key]

    def command(self, case: dict, args, mesh_path: str | None) -> list[str]:
        from cgal_runner import image_command

        p = case["params"]
        vol, kw, s = _surface(case["surface"], p["scale"])
        return image_command(
            self.exe,
            self.volume_file(case["surface"], p["scale"]),
            vol.shape,
            s.spacing,
            s.origin,
            kw["isovalue"],
            args.angle,
            p["radius"],
            p["distance"],
            args.cgal_error_bound,
            init=self.init,
            seed=args.seed,
            out=mesh_path,
        )


class VolumeInput(InputKind):
    """Volumes of known topology: rdmesh (cubic) against CGAL's gray-image
    Mesh_3 and marching cubes."""

    name = "volume"
    meshers = ("rdmesh", *CGAL_IMAGE, "marching_cubes")
    labels = {
        "rdmesh": "rdmesh (VolumeSurface, cubic)",
        "cgal_mesh_3_image": "CGAL Mesh_3, gray image (trilinear), make_mesh_3",
        "cgal_mesh_3_image_components": "the same, one initial seed per component "
        "(initialize_triangulation_from_gray_image)",
        "marching_cubes": "marching cubes",
    }

    def cases(self) -> tuple[str, ...]:
        return tuple(CASES)

    def check(self, mesher: str) -> str | None:
        try:
            import skimage  # noqa: F401
        except ImportError as exc:
            return f"scikit-image is not installed ({exc})"
        return None

    def adapter(self, mesher: str, record: dict, log) -> tuple[Any, str | None]:
        if mesher not in CGAL_IMAGE:
            return super().adapter(mesher, record, log)
        exe, why = build_cgal(record, log)
        return CgalImage(mesher, exe), why or self.check(mesher)

    def params(self, case: str, size: int) -> dict[str, Any]:
        n_base, area = _base(case)
        scale = max(CASES[case].min_scale, math.sqrt(size / n_base))
        scale = round(scale, 3)
        vol, _, _ = _surface(case, scale)
        r = math.sqrt(VERTICES_PER_AREA * area / size)
        return {"scale": scale, "shape": list(vol.shape), "radius": r, "distance": r}

    def run(self, mesher: str, spec: dict) -> dict[str, Any]:
        import rdmesh
        from meshers import _maxrss_mb

        vol, kw, s = _surface(spec["case"], spec["scale"])
        base = _maxrss_mb()
        if mesher == "rdmesh":
            t0 = time.perf_counter()
            m = rdmesh.mesh_surface(
                s,
                angle_bound=spec["angle"],
                radius_bound=spec["radius"],
                distance_bound=spec["distance"],
                seed=spec["seed"],
            )
            seconds = time.perf_counter() - t0
            v, f = m.vertices, m.faces
            evaluations = int(m.stats.get("evaluations", 0))
            extra = {"complete": bool(m.complete), "rounds": m.stats.get("rounds")}
        else:
            import skimage.measure  # noqa: F401  (imported before the clock starts)

            t0 = time.perf_counter()
            v, f = _marching_cubes(vol, kw, s.origin)
            seconds = time.perf_counter() - t0
            evaluations, extra = int(vol.size), {"samples": int(vol.size)}
        return mesh_run(
            spec.get("out"),
            v,
            f,
            seconds=seconds,
            evaluations=evaluations,
            baseline_rss_mb=base,
            extra={"shape": list(vol.shape), **extra},
        )

    def quality(
        self,
        case: str,
        params: dict,
        vertices,
        faces,
        *,
        reference_samples: int,
        seed: int,
        angle: float,
    ) -> dict[str, Any]:
        from metrics import hausdorff

        _, _, s = _surface(case, params["scale"])
        ref = _reference(case, params["scale"], reference_samples)
        euler = list(CASES[case].euler)
        h = hausdorff(s, vertices, faces, ref, seed=seed) if len(faces) else None
        expected = {
            "expected_components": len(euler),
            "expected_euler": sum(euler),
            "expected_per_component": euler,
        }
        return quality_entry(vertices, faces, h, angle, expected, voxel=float(s.spacing.min()))


@lru_cache(maxsize=2)
def _reference(case: str, scale: float, n: int) -> np.ndarray:
    """``n`` points on the cubic interpolant's isosurface (``metrics.surface_reference``)."""
    from metrics import surface_reference

    _, _, s = _surface(case, scale)
    lo, hi = s.box
    pad = 0.05 * (hi - lo)
    return surface_reference(s, n, bbox=(lo - pad, hi + pad))


INPUT = VolumeInput()
