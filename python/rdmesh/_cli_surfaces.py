"""Surfaces from command-line arguments: what ``rdmesh mesh`` and ``rdmesh
remesh`` mesh, and what each line of an ``rdmesh batch`` job file makes on a
worker (so both make the same surface). Errors are :class:`_CliError`."""

from __future__ import annotations

import math
import os

from .surfaces import SURFACES
from .surfaces.expressions import CONSTANTS, VARIABLES, parse_expression
from .surfaces.oracle import ImplicitSurface


class _CliError(Exception):
    """A usage error: reported in one line, exit status 2."""


def _features(args):
    """The surface's ``features=`` from ``--features``/``--no-features``."""
    if args.no_features:
        return "none"
    if args.features is None:
        return None
    from .features.polyline_file import read_polylines

    _check_file(args.features)
    return read_polylines(args.features)


def _check_file(path: str) -> None:
    """A one-line error unless ``path`` is a file."""
    if not os.path.isfile(path):
        why = "a folder, not a file" if os.path.isdir(path) else "no such file"
        raise _CliError(f"cannot read {path!r}: {why}")


def _mesh_file_surface(
    path: str, feature_angle="auto", features=None, holes: str = "keep"
) -> ImplicitSurface:
    """The :class:`MeshSurface` of the mesh file ``path`` (``remesh`` and ``batch``)."""
    import trimesh

    from .surfaces.mesh import MeshSurface

    _check_file(path)
    try:
        loaded = trimesh.load(path, force="mesh")
    except Exception as exc:  # noqa: BLE001 - trimesh's loaders raise many types
        raise _CliError(f"cannot read {path!r} as a mesh: {_one_line(exc)}") from None
    return MeshSurface(
        loaded, name=os.path.basename(path), feature_angle=feature_angle, features=features,
        holes=holes,
    )  # fmt: skip


#: With ``--clip-box`` and no sphere, the box's circumscribed sphere enlarged by this.
_CLIP_SPHERE_MARGIN = 1.1


def _surface(args) -> ImplicitSurface:
    """The built-in surface, the expression or the volume (.npy) named by SURFACE,
    clipped to ``--clip-box`` if given."""
    text = args.surface.strip()
    if _is_volume(args):
        return _volume_surface(args)
    sphere = args.sphere
    if args.bound is not None:
        sphere = ((0.0, 0.0, 0.0), args.bound)
    box = None
    if args.clip_box is not None:
        lo, hi = args.clip_box[:3], args.clip_box[3:]
        flat = [axis for axis, a, b in zip("xyz", lo, hi, strict=True) if not a < b]
        if flat:
            raise _CliError(
                f"--clip-box X0 Y0 Z0 X1 Y1 Z1 needs X0 < X1, Y0 < Y1 and Z0 < Z1; not on "
                f"{', '.join(flat)}"
            )
        box = (lo, hi)
        if sphere is None:
            # The box's circumscribed sphere, a little enlarged.
            centre = tuple(0.5 * (a + b) for a, b in zip(lo, hi, strict=True))
            half = 0.5 * math.dist(lo, hi)
            sphere = (centre, _CLIP_SPHERE_MARGIN * half)
    key = text.lower().replace("-", "_").replace(" ", "_")
    if key in SURFACES:
        surface = SURFACES[key].make()
        if sphere is None and box is None and not args.features and not args.no_features:
            return surface
        return ImplicitSurface(
            surface.f, sphere or surface.bounding_sphere, gradient=surface.gradient,
            name=surface.name, clip_box=box, features=_features(args),
        )  # fmt: skip
    if text.isidentifier() and text not in VARIABLES and text not in CONSTANTS:
        raise _CliError(
            f"unknown surface {args.surface!r}: built-in surfaces are {', '.join(SURFACES)}; "
            "or give an expression in x, y and z with --bound or --sphere"
        )
    parse_expression(text)  # report a bad expression before a missing sphere
    if sphere is None:
        raise _CliError(
            f"the expression {text!r} needs a bounding sphere: give --bound R or "
            "--sphere cx,cy,cz,R (or --clip-box)"
        )
    return ImplicitSurface.from_expression(
        text, bounding_sphere=sphere, clip_box=box, features=_features(args)
    )


_VOLUME_OPTIONS = ("isovalue", "spacing", "origin", "inside", "interpolation", "border")


def _is_volume(args) -> bool:
    """True if SURFACE names a .npy file; volume options need one."""
    if args.surface.strip().lower().endswith(".npy"):
        return True
    given = [o for o in _VOLUME_OPTIONS if getattr(args, o, None) is not None]
    if given:
        raise _CliError(f"--{given[0]} applies only to volumes: give SURFACE as a .npy file")
    return False


def _volume_surface(args) -> ImplicitSurface:
    """The isosurface of the volume in the .npy file SURFACE (closed by its box, or
    clipped to it with ``--border clipped``)."""
    import numpy as np

    from .surfaces.volume import VolumeSurface

    path = args.surface.strip()
    if args.bound is not None or args.sphere is not None:
        raise _CliError("--bound and --sphere do not apply to a volume: its box bounds it")
    if args.clip_box is not None:
        raise _CliError(
            "--clip-box does not apply to a volume: use --border clipped to clip it to its box"
        )
    try:
        volume = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise _CliError(f"no such volume file: {path!r}") from None
    except ValueError as exc:
        raise _CliError(f"cannot read the volume {path!r}: {exc}") from None
    if not isinstance(volume, np.ndarray):
        raise _CliError(f"{path!r} holds several arrays; save one 3-D array with numpy.save")
    opts = {k: getattr(args, k) for k in _VOLUME_OPTIONS if getattr(args, k) is not None}
    return VolumeSurface(volume, name=os.path.basename(path), features=_features(args), **opts)


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__
