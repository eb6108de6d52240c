"""The ``rdmesh`` command line: ``mesh``, ``remesh``, ``batch``, ``demo`` and ``list``.

``rdmesh mesh SURFACE -o OUT`` meshes a built-in surface (``rdmesh list``) or
an expression in x, y and z (``"x**2 + y**2 + z**2 - 1"``, with ``--bound R``
or ``--sphere cx,cy,cz,R``), optionally clipped to a box (``--clip-box X0 Y0 Z0
X1 Y1 Z1``: the part inside it, with a boundary on its faces), and writes the
mesh in the format its extension names, and with ``--png`` a picture.
``rdmesh remesh IN -o OUT`` remeshes a triangle mesh file
(:class:`rdmesh.MeshSurface`). ``rdmesh batch JOBS.jsonl --out DIR`` meshes
the jobs of a JSONL file in parallel on a Dask cluster (:mod:`rdmesh.batch`),
writing ``DIR/<name>.ply`` and ``DIR/manifest.jsonl``; a second run resumes.
``rdmesh demo`` meshes a built-in surface and writes the mesh and a picture.

Output: the summary goes to stdout; the progress bar (runs over a second),
log messages and errors go to stderr. ``--quiet`` keeps stderr silent unless
something goes wrong.

Exit status
-----------
0
    Success.
1
    A budget (``--max-vertices``, ``--time-limit``) stopped refinement; the
    partial mesh was written and stderr says so. ``batch``: some job stopped
    or failed, or a line of the jobs file is bad (the others ran).
2
    Bad input: unknown surface, bad expression, bad option, unwritable output,
    a surface function that fails. One line on stderr, no traceback.
130
    Interrupted (Ctrl-C); the partial mesh was written if refinement had
    started.

This is the only module of rdmesh that prints.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import math
import os
import sys

from . import __version__, core
from ._cli_surfaces import (  # noqa: F401 - used by the tests and the batch jobs
    _VOLUME_OPTIONS,
    _check_file,
    _CliError,
    _features,
    _is_volume,
    _mesh_file_surface,
    _one_line,
    _surface,
    _volume_surface,
)
from ._errors import Interrupted, RdmeshError, StoppedEarly
from .api import METHODS, mesh_surface
from .io.result import MESH_FORMATS, SurfaceMesh
from .refine.methods import TOPOLOGIES
from .surfaces import SURFACES, get
from .surfaces.builtin import BUILTIN_EXPRESSIONS
from .surfaces.oracle import ImplicitSurface

EXIT_OK, EXIT_BUDGET, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130

log = logging.getLogger("rdmesh")


class _Parser(argparse.ArgumentParser):
    """argparse that reports errors in one line with exit status 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise _CliError(message)


# -- option types -------------------------------------------------------------------


def _number(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"must be finite: {text!r}")
    return v


def _positive_float(text: str) -> float:
    v = _number(text)
    if v <= 0:
        raise argparse.ArgumentTypeError(f"must be positive: {text!r}")
    return v


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1: {text!r}")
    return v


def _angle(text: str) -> float:
    v = _number(text)
    if not 0 <= v <= 30:
        raise argparse.ArgumentTypeError(f"must be between 0 and 30 degrees: {text!r}")
    return v


def _sphere(text: str) -> tuple[tuple[float, float, float], float]:
    parts = [p.strip() for p in text.split(",")]
    if len(parts) != 4:
        raise argparse.ArgumentTypeError(f"expected cx,cy,cz,R (4 numbers), got {text!r}")
    cx, cy, cz = (_number(p) for p in parts[:3])
    return (cx, cy, cz), _positive_float(parts[3])


def _pixels(text: str) -> int:
    v = _positive_int(text)
    if not 16 <= v <= 10_000:
        raise argparse.ArgumentTypeError(f"must be between 16 and 10000 pixels: {text!r}")
    return v


# -- the parser ---------------------------------------------------------------------

_EPILOG = (
    "exit status: 0 success; 1 a budget stopped the run (partial mesh written); "
    "2 bad input; 130 interrupted (partial mesh written)"
)


def _add_output_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--png-size",
        type=_pixels,
        default=800,
        metavar="PIXELS",
        help="width and height of the picture (default 800)",
    )
    p.add_argument(
        "--quiet",
        "-q",
        action="store_true",
        help="nothing on stderr but errors: no progress bar, no log messages",
    )
    p.add_argument("--verbose", "-v", action="store_true", help="log every round on stderr")


def _parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="rdmesh",
        description="Mesh implicit surfaces f(x, y, z) = 0 by restricted Delaunay refinement.",
        epilog=_EPILOG,
    )
    p.add_argument(
        "--version", action="version", version=f"rdmesh {__version__} (CGAL {core.CGAL_VERSION})"
    )
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    mesh = sub.add_parser(
        "mesh",
        help="mesh a built-in surface or an expression in x, y and z",
        description=(
            "Mesh SURFACE: a built-in surface (see 'rdmesh list') or an expression in x, y "
            "and z that is negative inside, such as 'x**2 + y**2 + z**2 - 1', with --bound "
            "or --sphere. Expressions use numbers, x y z, pi e tau, + - * / ** and math "
            "functions (sin cos tan exp log sqrt abs min max hypot atan2 ...). Quote them; "
            "put '--' before one that starts with '-'. For a built-in surface, --bound or "
            "--sphere replaces its bounding sphere. --clip-box meshes only the part inside a "
            "box, with a boundary on its faces."
        ),
        epilog=_EPILOG,
    )
    mesh.add_argument("surface", metavar="SURFACE", help="built-in name or expression")
    mesh.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="OUT",
        help=f"mesh file; format by extension: {' '.join(MESH_FORMATS)}",
    )
    where = mesh.add_mutually_exclusive_group()
    where.add_argument(
        "--bound",
        type=_positive_float,
        metavar="R",
        help="bounding sphere of radius R about the origin",
    )
    where.add_argument(
        "--sphere",
        type=_sphere,
        metavar="CX,CY,CZ,R",
        help="bounding sphere (write --sphere=-1,0,0,2 if CX is negative)",
    )
    mesh.add_argument(
        "--clip-box",
        type=_number,
        nargs=6,
        metavar=("X0", "Y0", "Z0", "X1", "Y1", "Z1"),
        help="mesh only the part inside the box from (X0, Y0, Z0) to (X1, Y1, Z1), with a "
        "boundary on its faces (topology manifold-with-boundary); the box must lie inside "
        "the bounding sphere, which defaults to the box's circumscribed sphere enlarged by 10%%",
    )
    _add_run_options(mesh, method=True)
    _add_volume_options(mesh)
    _add_output_options(mesh)

    demo = sub.add_parser(
        "demo", help="mesh a built-in surface, write the mesh and a picture", epilog=_EPILOG
    )
    demo.add_argument(
        "--surface",
        default="tanglecube",
        help="built-in surface (default tanglecube; see 'rdmesh list')",
    )
    demo.add_argument(
        "-o",
        "--output",
        default="out/demo.ply",
        metavar="OUT",
        help="mesh file (default out/demo.ply)",
    )
    demo.add_argument("--png", default="out/demo.png", help="picture (default out/demo.png)")
    _add_output_options(demo)

    sub.add_parser("list", help="list the built-in surfaces")
    _add_remesh_parser(sub)
    _add_batch_parser(sub)
    return p


def _add_run_options(p: argparse.ArgumentParser, method: bool) -> None:
    """The criteria, method, budgets and picture options that ``mesh`` and ``remesh`` share."""
    p.add_argument(
        "--angle",
        type=_angle,
        default=30.0,
        metavar="A",
        help="smallest angle in degrees, at most 30 (default 30; 0 = off)",
    )
    p.add_argument(
        "--radius",
        type=_positive_float,
        metavar="R",
        help="largest surface Delaunay ball radius (default: bounding radius / 20)",
    )
    p.add_argument(
        "--distance",
        type=_positive_float,
        metavar="D",
        help="largest centre-to-surface distance (default off)"
        if method
        else "largest centre-to-surface distance; the input and the output are measured "
        "against each other at it (default off: measured at the radius bound)",
    )
    if method:
        p.add_argument(
            "--method", default="boissonnat-oudot", choices=METHODS, help="refinement algorithm"
        )
    p.add_argument(
        "--topology",
        default=None,
        choices=TOPOLOGIES,
        help="what the last stage repairs, as CGAL's tags (default manifold; "
        "manifold-with-boundary with --clip-box or a volume with --border clipped)",
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument(
        "--workers",
        type=_positive_int,
        default=1,
        metavar="N",
        help="threads evaluating the surface at once (default 1)",
    )
    p.add_argument(
        "--max-vertices",
        type=_positive_int,
        metavar="N",
        help="stop at N vertices; the partial mesh is written, exit status 1",
    )
    p.add_argument(
        "--time-limit",
        type=_positive_float,
        metavar="SECONDS",
        help="stop after about this long; partial mesh written, exit status 1",
    )
    p.add_argument("--png", metavar="PNG", help="also write a shaded picture")
    p.add_argument(
        "--edge-size",
        type=_positive_float,
        metavar="L",
        help="largest mesh edge along feature curves (default: the radius bound); at most "
        "0.3 times the radius bound, the angle bound is held next to the curves too where "
        "refinement can",
    )
    feat = p.add_mutually_exclusive_group()
    feat.add_argument(
        "--features",
        metavar="FILE",
        help="feature curves to keep, in CGAL's polylines format (one per line: "
        "n x1 y1 z1 ... xn yn zn); they must lie on the surface and meet only at end points",
    )
    feat.add_argument(
        "--no-features",
        action="store_true",
        help="protect no curve (clip boundaries snapped, creases and sharp edges rounded); "
        "without it, the creases of an expression's min, max and abs are found and kept",
    )


def _run_options(args) -> dict:
    """``mesh_surface``'s keyword arguments from :func:`_add_run_options`' options."""
    out = dict(
        angle_bound=args.angle,
        radius_bound=args.radius,
        distance_bound=args.distance,
        topology=args.topology,
        seed=args.seed,
        max_vertices=args.max_vertices,
        time_limit=args.time_limit,
        workers=args.workers,
        edge_size=args.edge_size,
    )
    if hasattr(args, "method"):
        out["method"] = args.method
    return out


# -- remesh: triangle meshes (MeshSurface) ----------------------------------------------


def _add_remesh_parser(sub) -> None:
    """``rdmesh remesh IN -o OUT``: the options of ``mesh`` that apply to a mesh file."""
    rm = sub.add_parser(
        "remesh",
        help="remesh a triangle mesh file (its signed distance is the surface)",
        description=(
            "Remesh the triangle mesh in IN (any format trimesh reads: ply obj stl off glb "
            "...) by restricted Delaunay refinement of its signed distance. An open mesh's "
            "holes are kept, their rims protected (or closed, with --holes fill). Sharp "
            "creases are kept (--feature-angle)."
        ),
        epilog=_EPILOG,
    )
    rm.add_argument("input", metavar="IN", help="the mesh file to remesh")
    rm.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="OUT",
        help=f"mesh file; format by extension: {' '.join(MESH_FORMATS)}",
    )
    _add_run_options(rm, method=False)
    rm.add_argument(
        "--feature-angle",
        type=_feature_angle,
        default="auto",
        metavar="A",
        help="keep edges whose faces' normals differ by at least A degrees (default auto: "
        "60 unless the sharp edges look like noise; 0 = none)",
    )
    rm.add_argument(
        "--holes",
        choices=("keep", "fill"),
        default="keep",
        help="an open mesh's holes: keep them, with their rims as the mesh's boundary "
        "(default), or fill them (a closed mesh; the winding number's patches)",
    )
    _add_output_options(rm)
    rm.set_defaults(run=_remesh)


def _feature_angle(text: str) -> float | str | None:
    if text == "auto":
        return text
    try:
        a = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of degrees: {text!r}") from None
    if a == 0:
        return None
    if not 0 < a < 180:
        raise argparse.ArgumentTypeError(f"must be in (0, 180) degrees, or 0; got {text!r}")
    return a


def _remesh(args) -> int:
    surface = _mesh_file_surface(args.input, args.feature_angle, _features(args), args.holes)
    return _run(args, surface, **_run_options(args))


# -- batch: a JSONL file of jobs on a Dask cluster -------------------------------------

_BATCH_EPILOG = (
    "exit status: 0 every job ok; 1 some job stopped or failed, or a line is bad (the "
    "others ran); 2 bad usage (no jobs file, unwritable folder, no cluster); 130 "
    "interrupted (the manifest holds the jobs that ended; run again to resume)"
)


def _timeout(text: str) -> float | str | None:
    if text.strip().lower() in ("none", "off"):
        return None
    if text.strip().lower() == "auto":
        return "auto"
    return _positive_float(text)


def _add_batch_parser(sub) -> None:
    """``rdmesh batch JOBS.jsonl --out DIR``: many jobs in parallel on Dask."""
    b = sub.add_parser(
        "batch",
        help="mesh the jobs of a JSONL file in parallel (Dask), resumable",
        description=(
            "Mesh every job of JOBS.jsonl, one JSON object a line: 'name', one of "
            "'expression' (with 'bound' or 'sphere'), 'surface' (a built-in name) or 'input' "
            "(a mesh file, or a .npy volume with the volume options), and any of "
            "angle_bound radius_bound distance_bound method topology time_limit max_vertices "
            "seed (clip_box, and isovalue spacing origin inside interpolation border for "
            "volumes, as 'rdmesh mesh' takes them). Relative input paths are from the jobs "
            "file's folder. Each job makes the mesh of the single 'rdmesh mesh' or 'rdmesh "
            "remesh', and writes DIR/<name>.ply; DIR/manifest.jsonl gets one record per job "
            "as it ends. A second run skips the jobs the manifest holds as ok or stopped "
            "(unchanged, with their mesh in place) and runs the failed ones again. Needs "
            "Dask: pip install 'rdmesh[dask]'."
        ),
        epilog=_BATCH_EPILOG,
    )
    b.add_argument("jobs", metavar="JOBS.jsonl", help="the jobs, one JSON object a line")
    b.add_argument("--out", required=True, metavar="DIR", help="folder of the meshes and manifest")
    where = b.add_mutually_exclusive_group()
    where.add_argument(
        "--workers",
        type=_positive_int,
        metavar="N",
        help="worker processes of the local cluster (default: one per core)",
    )
    where.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on an existing Dask cluster (tcp://host:8786); its workers need rdmesh and "
        "must reach the input files and DIR at the same paths",
    )
    b.add_argument(
        "--memory-limit",
        metavar="SIZE",
        help="memory of each local worker, e.g. 4GiB (default: the machine's memory / N); a "
        "job that goes over fails with 'out of memory'",
    )
    b.add_argument(
        "--hard-timeout",
        type=_timeout,
        default="auto",
        metavar="SECONDS",
        help="end a job that has not answered after this long, restarting its worker "
        "(default auto: 2 x its time_limit + 30 s, none without time_limit; 'none': never)",
    )
    b.add_argument(
        "--retry-stopped",
        action="store_true",
        help="run again the jobs that the manifest holds as stopped by a budget",
    )
    b.add_argument(
        "--progress",
        action="store_true",
        help="show the progress bar even when stderr is not a terminal",
    )
    b.add_argument(
        "--quiet", "-q", action="store_true", help="no progress bar, only errors on stderr"
    )
    b.add_argument("--verbose", "-v", action="store_true", help="log more on stderr")
    b.set_defaults(run=_batch)


def _batch(args) -> int:
    from .batch.jobfile import read_jobs
    from .batch.manifest import FolderBusy, Manifest

    if args.memory_limit is not None and args.scheduler is not None:
        raise _CliError("--memory-limit applies to the local cluster, not with --scheduler")
    if args.memory_limit is not None:
        _check_memory_limit(args.memory_limit)
    _check_file(args.jobs)
    if os.path.exists(args.out) and not os.path.isdir(args.out):
        raise _CliError(f"--out {args.out!r} is a file, not a folder")
    try:
        lines, errors = read_jobs(args.jobs)
    except UnicodeDecodeError as exc:
        raise _CliError(f"cannot read {args.jobs!r}: not UTF-8 text ({exc.reason})") from None
    for error in errors:
        print(f"rdmesh: {args.jobs}:{error.line}: {error.message}", file=sys.stderr)
    # Dask logs its start and each worker it restarts through its own handlers (which
    # mesh_many quiets for a local cluster); the jobs' outcomes are reported here.
    dask_log = logging.getLogger("distributed")
    propagate = dask_log.propagate
    dask_log.propagate = bool(args.verbose)
    try:
        with Manifest(args.out) as manifest:
            counts, skipped = _batch_run(args, manifest, lines)
    except FolderBusy as exc:
        raise _CliError(str(exc)) from None
    finally:
        dask_log.propagate = propagate
    bad = f", {len(errors)} bad lines" if errors else ""
    print(
        f"rdmesh batch: {len(lines) + len(errors)} jobs: {counts['ok']} ok, "
        f"{counts['stopped']} stopped, {counts['failed']} failed{bad} ({skipped} done "
        f"before, skipped); manifest {manifest.path}"
    )
    clean = counts["stopped"] == counts["failed"] == 0 and not errors
    return EXIT_OK if clean else EXIT_BUDGET


def _batch_run(args, manifest, lines) -> tuple[dict[str, int], int]:
    """Run the jobs the manifest does not hold as done; returns the counts of each
    status (the skipped jobs' included) and the number skipped."""
    from tqdm import tqdm

    from .batch import mesh_many
    from .batch.bar import JobBar
    from .batch.manifest import record

    counts = dict.fromkeys(("ok", "stopped", "failed"), 0)
    todo = []
    for line in lines:
        if manifest.done(line, retry_stopped=args.retry_stopped):
            counts[manifest.records[line.name]["status"]] += 1
        else:
            todo.append(line)
    skipped = len(lines) - len(todo)
    if skipped:
        log.warning("%d of %d jobs are in %s as done; skipped", skipped, len(lines), manifest.path)
    outputs = [os.path.join(args.out, f"{line.name}.ply") for line in todo]
    for path in outputs:  # a job that runs again replaces its old mesh, or leaves none
        if os.path.exists(path):
            os.unlink(path)

    def on_result(result) -> None:
        line = todo[result.index]
        if result.output is not None and not os.path.isfile(result.output):
            result.status, result.output = "failed", None
            result.error = (
                f"the worker {result.worker} wrote the mesh, but it is not in {args.out!r} "
                "here: with --scheduler, --out must be a folder the workers share"
            )
        manifest.append(record(result, line, args.out))
        counts[result.status] += 1
        bar.update(result)
        if result.status != "ok":
            tqdm.write(
                f"rdmesh: {line.name} (line {line.line}) {result.status}: {result.error}",
                file=sys.stderr,
            )

    show = args.progress or (sys.stderr.isatty() and not args.quiet)
    with JobBar(len(lines), initial=skipped, disable=not show) as bar:
        if todo:
            with _batch_client(args.scheduler) as client:
                mesh_many(
                    [line.job(path) for line, path in zip(todo, outputs, strict=True)],
                    client=client,
                    n_workers=args.workers,
                    memory_limit="auto" if args.memory_limit is None else args.memory_limit,
                    hard_timeout=args.hard_timeout,
                    on_result=on_result,
                )
    return counts, skipped


def _check_memory_limit(text: str) -> None:
    try:
        from dask.utils import parse_bytes
    except ImportError:
        raise _CliError("rdmesh batch needs Dask: pip install 'rdmesh[dask]'") from None
    if text.strip().lower() == "auto":
        return
    try:
        size = parse_bytes(text)
    except (ValueError, TypeError):
        size = 0
    if size <= 0:
        raise _CliError(f"--memory-limit must be a size such as 4GiB or 500MB, got {text!r}")


@contextlib.contextmanager
def _batch_client(address: str | None):
    """A client of the cluster at ``address`` (closed afterwards), or None: a local one."""
    if address is None:
        yield None
        return
    try:
        from distributed import Client
    except ImportError:
        raise _CliError("rdmesh batch needs Dask: pip install 'rdmesh[dask]'") from None
    try:
        client = Client(address, timeout=30)
    except (OSError, TimeoutError, ValueError) as exc:
        raise _CliError(f"cannot reach the Dask scheduler {address!r}: {_one_line(exc)}") from None
    with client:
        yield client


# -- running --------------------------------------------------------------------------


def _check_writable(path: str, picture: bool = False) -> None:
    """Fail early, before meshing, if ``path`` cannot be written."""
    ext = os.path.splitext(path)[1].lower().lstrip(".")
    if picture and ext != "png":
        raise _CliError(f"the picture {path!r} must end in .png")
    if not picture and ext not in MESH_FORMATS:
        raise _CliError(
            f"cannot write {path!r}: unknown mesh format {ext!r}; use one of "
            f"{', '.join(MESH_FORMATS)}"
        )
    if os.path.isdir(path):
        raise _CliError(f"cannot write {path!r}: it is a folder")
    folder = os.path.dirname(os.path.abspath(path))
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as exc:
        raise _CliError(f"cannot create folder {folder!r}: {exc.strerror}") from None
    if not os.access(folder, os.W_OK):
        raise _CliError(f"cannot write to folder {folder!r}: permission denied")


# -- volumes: ``rdmesh mesh volume.npy --isovalue V [--spacing SX SY SZ] ...`` --------


def _add_volume_options(p: argparse.ArgumentParser) -> None:
    from .surfaces.volume import BORDERS, INSIDE, INTERPOLATIONS

    g = p.add_argument_group(
        "volumes",
        "SURFACE may be a 3-D numpy array saved as .npy: its isosurface is meshed, closed by "
        "the faces of the volume's box where it reaches them (or cut there: --border clipped)",
    )
    g.add_argument(
        "--isovalue", type=_number, metavar="V", help="level to mesh (default mid-range)"
    )
    g.add_argument(
        "--spacing",
        type=_positive_float,
        nargs=3,
        metavar=("SX", "SY", "SZ"),
        help="sample spacing per array axis (default 1 1 1)",
    )
    g.add_argument(
        "--origin",
        type=_number,
        nargs=3,
        metavar=("OX", "OY", "OZ"),
        help="position of sample [0, 0, 0] (default 0 0 0)",
    )
    g.add_argument(
        "--inside",
        choices=INSIDE,
        help="values greater (default; e.g. bone in CT) or less than the isovalue are inside",
    )
    g.add_argument(
        "--interpolation", choices=INTERPOLATIONS, help="cubic B-spline (default) or trilinear"
    )
    g.add_argument(
        "--border",
        choices=BORDERS,
        help="closed (default): closed by the box faces, watertight; clipped: cut at the box "
        "faces, a mesh with a boundary (topology manifold-with-boundary)",
    )


def _write(mesh: SurfaceMesh, args, title: str) -> str:
    """Write the mesh (and picture); returns what was written, for the messages."""
    mesh.save(args.output)
    if not args.png:
        return args.output
    mesh.render(args.png, title=title, size=args.png_size)
    return f"{args.output} and {args.png}"


def _run(args, surface: ImplicitSurface, **opts) -> int:
    from .progress import ProgressBar
    from .progress import available as progress_available

    _check_writable(args.output)
    if args.png:
        _check_writable(args.png, picture=True)
    name = surface.name if len(surface.name) <= 60 else surface.name[:57] + "..."
    log.info(
        "meshing %s (bounding sphere %s, radius %g)", name, surface.centre.tolist(), surface.radius
    )
    total = opts.get("max_vertices")
    try:
        # Without tqdm (an optional dependency) the run goes on without a bar.
        with ProgressBar(total=total, disable=args.quiet or not progress_available()) as bar:
            mesh = mesh_surface(surface, progress=bar.update, **opts)
    except StoppedEarly as exc:  # a budget, a stall or Ctrl-C: write the partial mesh
        interrupted = isinstance(exc, Interrupted)
        why = "interrupted" if interrupted else f"stopped early ({exc.reason or exc})"
        status = EXIT_INTERRUPTED if interrupted else EXIT_BUDGET
        if exc.mesh is None:
            print(f"rdmesh: {why}; no mesh to write", file=sys.stderr)
            return status
        wrote = _write(exc.mesh, args, f"{name} (partial)")
        print(exc.mesh.summary())
        print(f"rdmesh: {why}; wrote the partial mesh to {wrote}", file=sys.stderr)
        return status
    wrote = _write(mesh, args, name)
    print(f"{name}: wrote {wrote}")
    print(mesh.summary())
    return EXIT_OK


def _list() -> int:
    for name, info in SURFACES.items():
        print(
            f"{name:14s} {info.description} (components {info.components}, "
            f"Euler characteristic {info.euler})"
        )
    return EXIT_OK


def _during_interrupt(exc: BaseException) -> bool:
    """True if ``exc`` was raised while a KeyboardInterrupt was being handled."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def main(argv: list[str] | None = None) -> int:
    """Run the command line with ``argv`` (default ``sys.argv[1:]``); returns the exit status."""
    logger = logging.getLogger("rdmesh")
    level = logger.level
    try:
        args = _parser().parse_args(argv)
        if args.command == "list":
            return _list()
        logging.basicConfig(level=logging.WARNING, format="rdmesh: %(message)s")
        if args.quiet:
            logger.setLevel(logging.ERROR)
        elif args.verbose:
            logger.setLevel(logging.DEBUG)
        if hasattr(args, "run"):
            return args.run(args)
        if args.command == "demo":
            # The built-in written as an expression, so the topological-ball
            # method can prove its tests; a finer size than the API default,
            # so the picture shows the mesh.
            made = get(args.surface)
            key = args.surface.strip().lower().replace("-", "_").replace(" ", "_")
            surface = ImplicitSurface.from_expression(
                BUILTIN_EXPRESSIONS[key], made.bounding_sphere, name=made.name
            )
            return _run(args, surface, radius_bound=made.radius / 40, method="topological-ball")
        return _run(args, _surface(args), **_run_options(args))
    except KeyboardInterrupt:
        print("rdmesh: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (_CliError, ValueError, RdmeshError, OSError, ImportError) as exc:
        if _during_interrupt(exc):
            # Ctrl-C, then a failure while recovering the partial mesh.
            print(f"rdmesh: interrupted; no partial mesh: {_one_line(exc)}", file=sys.stderr)
            return EXIT_INTERRUPTED
        print(f"rdmesh: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    finally:
        logger.setLevel(level)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
