# SPDX-License-Identifier: GPL-3.0-or-later
"""Build and run the CGAL reference mesher (``benchmarks/cgal_reference``).

Standard library only (``write_volume`` imports numpy).  Nothing is printed; progress goes to the
``logging`` logger of this module.

Typical use::

    from cgal_runner import build_reference, run_reference

    exe = build_reference("benchmarks/build/cgal_reference")
    result = run_reference(exe, "surface_mesher", "torus",
                           angle=30, radius=0.01, distance=0.01)
    result["seconds"], result["vertices"]

``run_reference`` returns the JSON object printed by the program: ``mesher``,
``surface``, ``seconds`` (wall time of the meshing call only), ``vertices``,
``faces``, ``evaluations`` (implicit-function calls during meshing),
``cgal_version``, ``bounding_sphere`` ([cx, cy, cz, r]), the criteria,
``error_bound``, ``seed``, ``closed``, ``components`` and
``euler_characteristic`` of the output surface.

``mesh_3`` is make_mesh_3 with ``params::manifold()``, ``mesh_3_fast`` the
same without it.  ``surface_mesher_boundary`` is make_surface_mesh with
``Manifold_with_boundary_tag``, the only mesher of the ``CLIPPED_SURFACES``
(surfaces that cross their bounding sphere, ``tests/clipped_surfaces.py``).
``mesh_3_box`` is make_mesh_3 (as ``mesh_3_fast``) on a labeled domain: 0
outside an axis-aligned box, 1 where f < 0 inside it, 2 where f >= 0; it
outputs only the facets between subdomains 1 and 2 and is the only mesher of
the ``BOX_SURFACES`` (surfaces clipped to a box, their boxes defined in the
program as in ``tests/clipped_surfaces.py``); its JSON also has ``box`` and
``complex_facets`` (every facet of the complex, the box faces' included).
The floor of the benchmarks, CGAL's bulk
``Delaunay_triangulation_3(begin, end)`` of given points, runs with
``delaunay_command(exe, points_file)`` (points written by ``write_points``).

``mesh_3_image`` meshes the isosurface of a gray-level volume with Mesh_3's
gray-image domain (trilinear interpolation, values above the isovalue
inside, closed by the samples' box): ``write_volume(path, volume)`` writes
the samples as raw little-endian float32, ``image_command(exe, path, shape,
spacing, origin, isovalue, ...)`` is the command line; ``init`` is
``"random"`` (make_mesh_3's own initial points) or ``"components"`` (a seed
per connected component of the samples above the isovalue first).  Its JSON
has ``surface`` null and ``dims``, ``spacing``, ``origin``, ``isovalue``,
``init`` instead of ``bounding_sphere``.

Protected 1D features (issue 27):

- ``mesh_3_features``: make_mesh_3 on
  ``Mesh_domain_with_polyline_features_3<Labeled_mesh_domain_3>`` (the
  implicit domain of ``mesh_3``) with the polylines of a file protected:
  ``write_polylines(path, polylines)`` writes them (CGAL's text format, one
  polyline per line, ``n x1 y1 z1 ... xn yn zn``), ``features_command(exe,
  surface, path, edge_size, angle, radius, distance, ...)`` is the command
  line.  Polylines may meet only at their end points (CGAL 5.5 crashes
  otherwise, CGAL #7356): split them at shared interior points before writing
  (``write_polylines`` refuses a point shared with another polyline's
  interior, the program too).  ``FEATURE_SURFACES`` are the surfaces with
  creases: ``box`` and ``box_ball`` (their curves ``cad_shapes.box_curves``
  and ``box_ball_curves``) and the shapes of ``crease_shapes`` (issue 28).
- ``mesh_3_polyhedron``: make_mesh_3 on
  ``Polyhedral_mesh_domain_with_features_3`` of a closed triangle mesh (OFF,
  ``write_off``) after ``detect_features(feature_angle)``:
  ``polyhedron_command(exe, path, feature_angle, edge_size, angle, radius,
  distance, ...)``.

Both print, besides the usual keys, ``edge_size``, ``feature_vertices``
(triangulation vertices on a curve or a corner, ``in_dimension <= 1``),
``corner_vertices`` (``in_dimension == 0``), ``complex_edges``,
``domain_curves`` and ``domain_corners``; ``mesh_3_features`` also
``features`` (the file) and ``polylines`` (their number),
``mesh_3_polyhedron`` ``input``, ``feature_angle`` and ``detect_seconds``
(``detect_features`` alone; ``seconds`` includes it) with ``surface`` and
``error_bound`` null and ``evaluations`` 0.  ``run_command(cmd, what,
timeout)`` runs any of these command lines and parses the output.
"""

from __future__ import annotations

import json
import logging
import math
import os
import shutil
import subprocess
from collections.abc import Sequence
from pathlib import Path
from typing import Any

__all__ = [
    "BOUNDING_SPHERES",
    "BOX_SURFACES",
    "CLIPPED_SURFACES",
    "DEFAULT_BUILD_DIR",
    "IMAGE_INITS",
    "MESHERS",
    "SOURCE_DIR",
    "SURFACES",
    "CgalReferenceError",
    "build_reference",
    "FEATURE_MESHERS",
    "FEATURE_SURFACES",
    "delaunay_command",
    "features_command",
    "image_command",
    "parse_reference_output",
    "polyhedron_command",
    "read_polylines",
    "reference_command",
    "run_command",
    "run_reference",
    "write_off",
    "write_points",
    "write_polylines",
    "write_volume",
]

logger = logging.getLogger(__name__)

_HERE = Path(__file__).resolve().parent
SOURCE_DIR = _HERE / "cgal_reference"
DEFAULT_BUILD_DIR = _HERE / "build" / "cgal_reference"
_EXE_NAME = "cgal_reference"

MESHERS = ("surface_mesher", "surface_mesher_boundary", "mesh_3", "mesh_3_fast", "mesh_3_box")
SURFACES = (
    "sphere",
    "ellipsoid",
    "torus",
    "thin_torus",
    "double_torus",
    "tanglecube",
    "two_spheres",
    "blob_line",
)

#: The features modes (``features_command``, ``polyhedron_command``).
FEATURE_MESHERS = ("mesh_3_features", "mesh_3_polyhedron")

#: Surfaces with creases, for ``mesh_3_features`` (any mesher of SURFACES
#: meshes them too): the cube ``max(|x|,|y|,|z|) - 1`` and its union with the
#: ball of radius 0.8 about (1, 1, 1); the shapes of ``crease_shapes``
#: (issue 28: a rotated cube, a cylinder, a lens, a dimpled and a holed cube).
FEATURE_SURFACES = (
    "box", "box_ball", "box_rotated", "cylinder", "lens", "box_dimple", "box_hole",
)  # fmt: skip

#: How ``mesh_3_image`` finds its initial points.
IMAGE_INITS = ("random", "components")

#: Surfaces that leave their bounding sphere (``tests/clipped_surfaces.py``);
#: only ``surface_mesher_boundary`` meshes them.
CLIPPED_SURFACES = ("clipped_gyroid", "clipped_plane", "clipped_cylinder", "clipped_half_torus")

#: Surfaces clipped to a box (``tests/clipped_surfaces.py``, the boxes in
#: cgal_reference.cpp); only ``mesh_3_box`` meshes them.
BOX_SURFACES = ("box_gyroid", "box_plane")

#: Bounding sphere ((cx, cy, cz), r) the program hands to CGAL for each surface
#: (the table in cgal_reference.cpp): the centre is inside the surface, as
#: CGAL's initial-point search needs.  Other CGAL front ends that take a
#: sphere about the origin (pygalmesh) can translate the function by it.
BOUNDING_SPHERES = {
    "sphere": ((0.0, 0.0, 0.0), 2.0),
    "ellipsoid": ((0.0, 0.0, 0.0), 2.0),
    "torus": ((1.0, 0.0, 0.0), 2.5),
    "thin_torus": ((1.0, 0.0, 0.0), 2.2),
    "double_torus": ((1.0, 0.0, 0.0), 1.5),
    "tanglecube": ((1.25, 1.25, 1.25), 6.0),
    "two_spheres": ((1.05, 0.0, 0.0), 3.2),
    "blob_line": ((0.0, 0.0, 0.0), 2.0),
    "box": ((0.0, 0.0, 0.0), 2.0),
    "box_ball": ((0.2, 0.2, 0.2), 2.4),
    "box_rotated": ((0.0, 0.0, 0.0), 2.0),
    "cylinder": ((0.0, 0.0, 0.0), 2.0),
    "lens": ((0.0, 0.0, 0.0), 1.5),
    "box_dimple": ((0.0, 0.0, 0.0), 2.0),
    "box_hole": ((0.75, 0.0, 0.0), 2.5),
}

# Keys every successful run prints.
_REQUIRED_KEYS = (
    "mesher",
    "surface",
    "seconds",
    "vertices",
    "faces",
    "evaluations",
    "cgal_version",
)

PathLike = str | os.PathLike[str]


class CgalReferenceError(RuntimeError):
    """Building or running the reference program failed.

    ``returncode``, ``stdout`` and ``stderr`` hold what the failing command
    gave (``returncode`` is None after a timeout).
    """

    def __init__(
        self,
        message: str,
        *,
        returncode: int | None = None,
        stdout: str = "",
        stderr: str = "",
    ) -> None:
        super().__init__(message)
        self.returncode = returncode
        self.stdout = stdout
        self.stderr = stderr


def _cmake() -> str:
    cmake = shutil.which("cmake")
    if cmake is None:
        raise CgalReferenceError("cmake not found on PATH")
    return cmake


def _run_checked(cmd: Sequence[str], what: str, timeout: float | None) -> None:
    logger.info("%s: %s", what, " ".join(cmd))
    try:
        proc = subprocess.run(
            list(cmd), capture_output=True, text=True, timeout=timeout, check=False
        )
    except subprocess.TimeoutExpired as exc:
        raise CgalReferenceError(f"{what} timed out after {timeout} s") from exc
    if proc.returncode != 0:
        tail = (proc.stdout + proc.stderr).strip().splitlines()[-40:]
        raise CgalReferenceError(
            f"{what} failed (exit {proc.returncode}):\n" + "\n".join(tail),
            returncode=proc.returncode,
            stdout=proc.stdout,
            stderr=proc.stderr,
        )
    logger.debug("%s output:\n%s", what, proc.stdout)


def _sources() -> list:
    return [p for p in SOURCE_DIR.iterdir() if p.is_file()]


def _up_to_date(exe: Path, build_dir: Path) -> bool:
    if not exe.is_file() or not (build_dir / "CMakeCache.txt").is_file():
        return False
    built = exe.stat().st_mtime
    return all(p.stat().st_mtime <= built for p in _sources())


def build_reference(
    build_dir: PathLike = DEFAULT_BUILD_DIR,
    *,
    jobs: int = 2,
    force: bool = False,
    timeout: float | None = 1800.0,
) -> Path:
    """Configure and build the reference program; return the executable.

    Configures with CMake (Release) into ``build_dir`` if that has no
    CMakeCache.txt yet, then builds with ``jobs`` parallel jobs.  Nothing is
    run when the executable exists and is newer than every file of
    ``benchmarks/cgal_reference`` (unless ``force``).  A cold build takes
    about a minute (one translation unit, mostly CGAL templates).

    Raises CgalReferenceError if cmake is missing, CGAL is not found, the
    compilation fails or takes longer than ``timeout`` seconds per step.
    """
    build_dir = Path(build_dir).resolve()
    exe = build_dir / _EXE_NAME
    if not force and _up_to_date(exe, build_dir):
        logger.debug("CGAL reference up to date: %s", exe)
        return exe

    cmake = _cmake()
    if not (build_dir / "CMakeCache.txt").is_file():
        build_dir.mkdir(parents=True, exist_ok=True)
        _run_checked(
            [cmake, "-S", str(SOURCE_DIR), "-B", str(build_dir), "-DCMAKE_BUILD_TYPE=Release"],
            "configure CGAL reference",
            timeout,
        )
    # cmake --build re-runs the configure step itself if CMakeLists.txt changed.
    _run_checked(
        [cmake, "--build", str(build_dir), "--parallel", str(int(jobs))],
        "build CGAL reference",
        timeout,
    )
    if not exe.is_file():
        raise CgalReferenceError(f"build finished but {exe} does not exist")
    # make may leave the old executable untouched when nothing needed
    # rebuilding (e.g. a source file was only touched); refresh its time so the
    # up-to-date check above does not rebuild every call.
    if not _up_to_date(exe, build_dir):
        os.utime(exe)
    logger.info("CGAL reference built: %s", exe)
    return exe


def _number(name: str, value: float) -> str:
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return repr(v)


def reference_command(
    exe: PathLike,
    mesher: str,
    surface: str,
    angle: float,
    radius: float,
    distance: float,
    error_bound: float | None = None,
    *,
    seed: int | None = None,
    out: PathLike | None = None,
) -> list[str]:
    """The command line that runs the program once (see :func:`run_reference`).

    Raises ValueError for an unknown mesher or surface or a non-finite number.
    """
    if mesher not in MESHERS:
        raise ValueError(f"unknown mesher {mesher!r}; expected one of {MESHERS}")
    known = SURFACES + FEATURE_SURFACES + CLIPPED_SURFACES + BOX_SURFACES
    if surface not in known:
        raise ValueError(f"unknown surface {surface!r}; expected one of {known}")
    if surface in CLIPPED_SURFACES and mesher != "surface_mesher_boundary":
        raise ValueError(f"{surface!r} leaves its sphere: only surface_mesher_boundary meshes it")
    if (surface in BOX_SURFACES) != (mesher == "mesh_3_box"):
        raise ValueError(
            f"mesh_3_box meshes exactly the box surfaces {BOX_SURFACES}, not {surface!r} "
            f"with {mesher!r}"
        )
    cmd = [str(exe), "--mesher", mesher, "--surface", surface]
    return cmd + _criteria_args(angle, radius, distance, error_bound, seed, out)


def _criteria_args(angle, radius, distance, error_bound, seed, out) -> list[str]:
    """The options every meshing mode of the program takes."""
    args = [
        "--angle", _number("angle", angle),
        "--radius", _number("radius", radius),
        "--distance", _number("distance", distance),
    ]  # fmt: skip
    if error_bound is not None:
        args += ["--error-bound", _number("error_bound", error_bound)]
    if seed is not None:
        args += ["--seed", str(int(seed))]
    if out is not None:
        args += ["--out", str(out)]
    return args


def write_points(path: PathLike, points: Any) -> None:
    """Write points ((N, 3), finite) as text, ``x y z`` per line, 17 digits.

    What ``--mesher delaunay --points`` reads.
    """
    with open(path, "w") as fh:
        for p in points:
            x, y, z = (float(c) for c in p)
            fh.write(f"{x!r} {y!r} {z!r}\n")


def delaunay_command(exe: PathLike, points: PathLike) -> list[str]:
    """The command timing CGAL's bulk Delaunay_triangulation_3 of a points file."""
    return [str(exe), "--mesher", "delaunay", "--points", str(points)]


def write_volume(path: PathLike, volume: Any) -> None:
    """Write a 3-D volume as ``mesh_3_image`` reads it: raw little-endian
    float32, the first array axis (x) fastest."""
    import numpy as np

    vol = np.asarray(volume)
    if vol.ndim != 3:
        raise ValueError(f"a volume is 3-D, got shape {vol.shape}")
    vol.astype("<f4").ravel(order="F").tofile(str(path))


def _triple(name: str, values: Sequence[float]) -> str:
    if len(values) != 3:
        raise ValueError(f"{name} needs 3 values, got {values!r}")
    return ",".join(_number(name, v) for v in values)


def image_command(
    exe: PathLike,
    image: PathLike,
    shape: Sequence[int],
    spacing: Sequence[float],
    origin: Sequence[float],
    isovalue: float,
    angle: float,
    radius: float,
    distance: float,
    error_bound: float | None = None,
    *,
    init: str = "random",
    seed: int | None = None,
    out: PathLike | None = None,
) -> list[str]:
    """The command meshing a volume written by :func:`write_volume` with
    ``mesh_3_image`` (``shape`` its array shape, sample ``[i, j, k]`` at
    ``origin + (i, j, k) * spacing``, inside where it exceeds ``isovalue``).

    Raises ValueError for an unknown ``init`` or a non-finite number.
    """
    if init not in IMAGE_INITS:
        raise ValueError(f"unknown init {init!r}; expected one of {IMAGE_INITS}")
    if len(shape) != 3:
        raise ValueError(f"shape needs 3 values, got {shape!r}")
    cmd = [
        str(exe),
        "--mesher", "mesh_3_image",
        "--image", str(image),
        "--dims", ",".join(str(int(n)) for n in shape),
        "--spacing", _triple("spacing", spacing),
        "--origin", _triple("origin", origin),
        "--isovalue", _number("isovalue", isovalue),
        "--init", init,
    ]  # fmt: skip
    return cmd + _criteria_args(angle, radius, distance, error_bound, seed, out)


def _points_of(polyline: Any, index: int) -> list[tuple[float, float, float]]:
    """The points of one polyline as float triples, checked."""
    pts = [tuple(float(c) for c in p) for p in polyline]
    if any(len(p) != 3 for p in pts):
        raise ValueError(f"polyline {index}: points need 3 coordinates")
    if len(pts) < 2:
        raise ValueError(f"polyline {index}: needs at least 2 points, got {len(pts)}")
    if not all(math.isfinite(c) for p in pts for c in p):
        raise ValueError(f"polyline {index}: a coordinate is not finite")
    for i in range(1, len(pts)):
        if pts[i] == pts[i - 1]:
            raise ValueError(f"polyline {index}: points {i - 1} and {i} are equal")
    return pts


def write_polylines(path: PathLike, polylines: Any) -> None:
    """Write polylines for ``mesh_3_features``: one per line, ``n x1 y1 z1 ...
    xn yn zn`` (CGAL's polylines text format), 17 significant digits.

    ``polylines``: a sequence of ``(m, 3)`` point sequences (``m >= 2``); a
    closed loop repeats its first point last.  Polylines may meet only at
    their end points (CGAL #7356): ValueError for a point that is also in the
    interior of another polyline (or twice in one), two consecutive equal
    points, fewer than 2 points or a non-finite coordinate.
    """
    checked = [_points_of(pl, i) for i, pl in enumerate(polylines)]
    if not checked:
        raise ValueError("no polylines")
    where: dict[tuple[float, float, float], list[tuple[int, bool]]] = {}
    for k, pts in enumerate(checked):
        closed = pts[0] == pts[-1]
        for i, p in enumerate(pts[:-1] if closed else pts):
            where.setdefault(p, []).append((k, i == 0 or i == len(pts) - 1))
    for p, uses in where.items():
        if len(uses) > 1 and not all(end for _, end in uses):
            ks = sorted({k for k, _ in uses})
            raise ValueError(
                f"polylines {ks} share the point {p}, which is interior to one of them: "
                "polylines may meet only at their end points (CGAL #7356); split them there"
            )
    with open(path, "w") as fh:
        for pts in checked:
            fh.write(" ".join([str(len(pts))] + [repr(c) for p in pts for c in p]) + "\n")


def read_polylines(path: PathLike) -> list[list[tuple[float, float, float]]]:
    """The polylines of a file written by :func:`write_polylines`."""
    out = []
    with open(path) as fh:
        for line in fh:
            tok = line.split()
            if not tok:
                continue
            n = int(tok[0])
            if len(tok) != 1 + 3 * n:
                raise ValueError(f"{path}: {len(tok) - 1} coordinates for {n} points")
            xyz = [float(t) for t in tok[1:]]
            out.append([tuple(xyz[i : i + 3]) for i in range(0, len(xyz), 3)])
    return out


def write_off(path: PathLike, vertices: Any, faces: Any) -> None:
    """Write a triangle mesh as OFF (17 significant digits), what
    ``mesh_3_polyhedron --input`` reads."""
    verts = [tuple(float(c) for c in v) for v in vertices]
    tris = [tuple(int(i) for i in f) for f in faces]
    with open(path, "w") as fh:
        fh.write(f"OFF\n{len(verts)} {len(tris)} 0\n")
        for x, y, z in verts:
            fh.write(f"{x!r} {y!r} {z!r}\n")
        for a, b, c in tris:
            fh.write(f"3 {a} {b} {c}\n")


def features_command(
    exe: PathLike,
    surface: str,
    features: PathLike,
    edge_size: float,
    angle: float,
    radius: float,
    distance: float,
    error_bound: float | None = None,
    *,
    seed: int | None = None,
    out: PathLike | None = None,
) -> list[str]:
    """The command meshing ``surface`` with ``mesh_3_features``: the polylines
    of ``features`` (:func:`write_polylines`) protected with balls of radius at
    most ``edge_size``.

    Raises ValueError for an unknown surface or a non-finite number.
    """
    known = SURFACES + FEATURE_SURFACES
    if surface not in known:
        raise ValueError(f"unknown surface {surface!r}; expected one of {known}")
    cmd = [
        str(exe),
        "--mesher", "mesh_3_features",
        "--surface", surface,
        "--features", str(features),
        "--edge-size", _number("edge_size", edge_size),
    ]  # fmt: skip
    return cmd + _criteria_args(angle, radius, distance, error_bound, seed, out)


def polyhedron_command(
    exe: PathLike,
    mesh: PathLike,
    feature_angle: float,
    edge_size: float,
    angle: float,
    radius: float,
    distance: float,
    *,
    seed: int | None = None,
    out: PathLike | None = None,
) -> list[str]:
    """The command remeshing the closed triangle mesh ``mesh`` (OFF,
    :func:`write_off`) with ``mesh_3_polyhedron``: its edges whose normals
    differ by ``feature_angle`` degrees or more protected (CGAL's
    ``detect_features``).  There is no oracle error bound (exact AABB-tree
    intersections).

    Raises ValueError for a non-finite number.
    """
    cmd = [
        str(exe),
        "--mesher", "mesh_3_polyhedron",
        "--input", str(mesh),
        "--feature-angle", _number("feature_angle", feature_angle),
        "--edge-size", _number("edge_size", edge_size),
    ]  # fmt: skip
    return cmd + _criteria_args(angle, radius, distance, None, seed, out)


def parse_reference_output(
    returncode: int, stdout: str, stderr: str, what: str = "cgal_reference"
) -> dict[str, Any]:
    """Turn one finished run of the program into its JSON result.

    Raises ValueError for exit code 2 (arguments rejected) and
    CgalReferenceError for any other failure or unreadable output.
    """
    if returncode == 2:
        first = stderr.strip().splitlines()[:1]
        raise ValueError(first[0] if first else "cgal_reference rejected its arguments")
    if returncode != 0:
        raise CgalReferenceError(
            f"{what} failed (exit {returncode}): {stderr.strip()}",
            returncode=returncode,
            stdout=stdout,
            stderr=stderr,
        )
    lines = [line for line in stdout.splitlines() if line.strip()]
    try:
        result = json.loads(lines[-1])
    except (IndexError, json.JSONDecodeError) as exc:
        raise CgalReferenceError(
            f"unexpected output from {what}: {stdout!r}",
            returncode=returncode,
            stdout=stdout,
            stderr=stderr,
        ) from exc
    if not isinstance(result, dict) or any(k not in result for k in _REQUIRED_KEYS):
        raise CgalReferenceError(
            f"incomplete result from {what}: {result!r}",
            returncode=returncode,
            stdout=stdout,
            stderr=stderr,
        )
    if stderr.strip():
        logger.debug("stderr of %s: %s", what, stderr.strip())
    return result


def run_command(
    cmd: Sequence[str], what: str = "cgal_reference", timeout: float | None = 3600.0
) -> dict[str, Any]:
    """Run one command line of the program (e.g. :func:`features_command`)
    and return its JSON result; errors as :func:`run_reference`."""
    logger.debug("run: %s", " ".join(cmd))
    try:
        proc = subprocess.run(
            list(cmd), capture_output=True, text=True, timeout=timeout, check=False
        )
    except subprocess.TimeoutExpired as exc:
        raise CgalReferenceError(
            f"{what} timed out after {timeout} s",
            stdout=exc.stdout if isinstance(exc.stdout, str) else "",
            stderr=exc.stderr if isinstance(exc.stderr, str) else "",
        ) from exc
    except OSError as exc:
        raise CgalReferenceError(f"cannot run {cmd[0]}: {exc}") from exc
    return parse_reference_output(proc.returncode, proc.stdout, proc.stderr, what=what)


def run_reference(
    exe: PathLike,
    mesher: str,
    surface: str,
    angle: float,
    radius: float,
    distance: float,
    error_bound: float | None = None,
    timeout: float | None = 3600.0,
    *,
    seed: int | None = None,
    out: PathLike | None = None,
) -> dict[str, Any]:
    """Run the reference program once and return its JSON result as a dict.

    ``mesher`` one of MESHERS; ``surface`` one of SURFACES (or of
    CLIPPED_SURFACES, BOX_SURFACES with their mesher);
    ``angle`` (degrees), ``radius`` and ``distance`` are the CGAL facet
    criteria; ``error_bound`` the relative error of the implicit oracle
    (None: the program's default, 1e-6); ``seed`` CGAL's random seed
    (None: 0); ``out`` an OFF file to write the surface to.

    Raises ValueError for arguments the program rejects (its exit code 2),
    CgalReferenceError for any other failure, including a run longer than
    ``timeout`` seconds (the process is killed then; None = no limit).
    """
    cmd = reference_command(
        exe, mesher, surface, angle, radius, distance, error_bound, seed=seed, out=out
    )
    logger.debug("run: %s", " ".join(cmd))
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, check=False)
    except subprocess.TimeoutExpired as exc:
        raise CgalReferenceError(
            f"{mesher} on {surface} timed out after {timeout} s",
            stdout=exc.stdout if isinstance(exc.stdout, str) else "",
            stderr=exc.stderr if isinstance(exc.stderr, str) else "",
        ) from exc
    except OSError as exc:
        raise CgalReferenceError(f"cannot run {exe}: {exc}") from exc
    return parse_reference_output(
        proc.returncode, proc.stdout, proc.stderr, what=f"{mesher} on {surface}"
    )
