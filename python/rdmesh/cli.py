"""The ``rdmesh`` command line: ``demo``, ``mesh`` and ``list``."""

from __future__ import annotations

import argparse
import logging
import os
import sys

from . import __version__, _rdt
from ._errors import BudgetExceeded, RdmeshError
from .api import METHODS, mesh_surface
from .refine import TOPOLOGIES
from .result import MESH_FORMATS
from .surfaces import SURFACES, get


class _Parser(argparse.ArgumentParser):
    """argparse that reports errors in one line with exit status 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise _CliError(message)


class _CliError(Exception):
    pass


def _positive_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not v > 0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"must be positive and finite: {text!r}")
    return v


def _parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="rdmesh", description="Mesh implicit surfaces by restricted Delaunay refinement."
    )
    p.add_argument(
        "--version", action="version", version=f"rdmesh {__version__} (CGAL {_rdt.CGAL_VERSION})"
    )
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    demo = sub.add_parser("demo", help="mesh a built-in surface, write the mesh and a picture")
    demo.add_argument(
        "--surface", default="tanglecube", help="built-in surface (default tanglecube)"
    )
    demo.add_argument(
        "-o", "--output", default="out/demo.ply", help="mesh file (default out/demo.ply)"
    )
    demo.add_argument("--png", default="out/demo.png", help="picture (default out/demo.png)")
    demo.add_argument("--quiet", action="store_true", help="no log output")

    mesh = sub.add_parser("mesh", help="mesh a built-in surface")
    mesh.add_argument("surface", help="built-in surface name (see 'rdmesh list')")
    mesh.add_argument("-o", "--output", required=True, help="mesh file: .ply .obj .stl .off .glb")
    mesh.add_argument("--angle", type=float, default=30.0, help="angle bound in degrees (<= 30)")
    mesh.add_argument("--radius", type=_positive_float, help="surface Delaunay ball radius bound")
    mesh.add_argument("--distance", type=_positive_float, help="centre-to-surface distance bound")
    mesh.add_argument("--method", default="boissonnat-oudot", choices=METHODS)
    mesh.add_argument("--topology", default="manifold", choices=TOPOLOGIES)
    mesh.add_argument("--seed", type=int, default=0)
    mesh.add_argument("--max-vertices", type=int)
    mesh.add_argument("--time-limit", type=_positive_float, help="seconds")
    mesh.add_argument("--png", help="also write a picture")
    mesh.add_argument("--quiet", action="store_true", help="no log output")

    sub.add_parser("list", help="list the built-in surfaces")
    return p


def _check_writable(path: str, mesh: bool = True) -> None:
    ext = os.path.splitext(path)[1].lower().lstrip(".")
    if mesh and ext not in MESH_FORMATS:
        raise _CliError(
            f"cannot write {path!r}: unknown mesh format {ext!r}; use one of "
            f"{', '.join(MESH_FORMATS)}"
        )
    if not mesh and ext != "png":
        raise _CliError(f"the picture {path!r} must end in .png")
    folder = os.path.dirname(os.path.abspath(path))
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as exc:
        raise _CliError(f"cannot create folder {folder!r}: {exc.strerror}") from None
    if not os.access(folder, os.W_OK):
        raise _CliError(f"cannot write to {folder!r}")


def _write(mesh, args) -> None:
    mesh.save(args.output)
    if args.png:
        from .render import render

        render(mesh.vertices, mesh.faces, args.png, title=getattr(args, "title", None))


def _run_mesh(args, surface_name: str, **opts) -> int:
    surface = get(surface_name)
    _check_writable(args.output)
    if args.png:
        _check_writable(args.png, mesh=False)
    from .result import SurfaceMesh

    args.title = surface.name
    try:
        mesh: SurfaceMesh = mesh_surface(surface, **opts)
    except BudgetExceeded as exc:
        _write(exc.mesh, args)
        print(exc.mesh.summary())
        print(f"rdmesh: {exc}; wrote the partial mesh to {args.output}", file=sys.stderr)
        return 1
    _write(mesh, args)
    print(f"{surface.name}: wrote {args.output}" + (f" and {args.png}" if args.png else ""))
    print(mesh.summary())
    return 0


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    try:
        args = _parser().parse_args(argv)
        if getattr(args, "quiet", False):
            logging.getLogger("rdmesh").setLevel(logging.ERROR)
        else:
            logging.basicConfig(level=logging.WARNING, format="rdmesh: %(message)s")
        if args.command == "list":
            for name, info in SURFACES.items():
                print(
                    f"{name:14s} {info.description} (components {info.components}, "
                    f"Euler characteristic {info.euler})"
                )
            return 0
        if args.command == "demo":
            return _run_mesh(args, args.surface, angle_bound=30.0)
        return _run_mesh(
            args,
            args.surface,
            angle_bound=args.angle,
            radius_bound=args.radius,
            distance_bound=args.distance,
            topology=args.topology,
            method=args.method,
            seed=args.seed,
            max_vertices=args.max_vertices,
            time_limit=args.time_limit,
        )
    except KeyboardInterrupt:
        print("rdmesh: interrupted", file=sys.stderr)
        return 130
    except (_CliError, ValueError, RdmeshError, OSError) as exc:
        print(f"rdmesh: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
