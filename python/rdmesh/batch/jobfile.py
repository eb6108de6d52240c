"""Job files for ``rdmesh batch``: one JSON object per line (JSONL).

Each line names a job and its surface, as ``rdmesh mesh`` or ``rdmesh remesh``
would take it, and any of the options they take::

    {"name": "torus-fine", "surface": "torus", "radius_bound": 0.02}
    {"name": "ball", "expression": "x**2 + y**2 + z**2 - 1", "bound": 2}
    {"name": "bunny", "input": "meshes/bunny.ply", "distance_bound": 0.001}
    {"name": "ct", "input": "ct.npy", "isovalue": 300, "spacing": [0.5, 0.5, 1]}

A line is checked whole before anything runs; a bad one becomes a
:class:`LineError` that names it, and the others still run. The surface is
made on the worker, by the command line's own functions, so that a job makes
exactly the mesh of the single command.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from ..surfaces.oracle import ImplicitSurface
from .job import Job

#: Where a job's surface comes from: exactly one of these keys.
SOURCES = ("expression", "surface", "input")
#: The bounding sphere and clip box of an expression or a built-in surface.
PLACEMENT = ("bound", "sphere", "clip_box")
#: The options of a volume (an ``input`` ending in .npy), as ``rdmesh mesh`` takes them.
VOLUME = ("isovalue", "spacing", "origin", "inside", "interpolation", "border")
#: The ``mesh_surface`` keywords a line may set (those of ``rdmesh mesh``).
MESH_OPTIONS = (
    "angle_bound",
    "radius_bound",
    "distance_bound",
    "method",
    "topology",
    "time_limit",
    "max_vertices",
    "seed",
    "edge_size",
)
KEYS = ("name", *SOURCES, *PLACEMENT, *VOLUME, *MESH_OPTIONS)

#: A job's name is its output file's name: letters, digits and ``._+=,@-``.
_NAME = re.compile(r"\w[\w.+=,@-]{0,199}")


class LineError(ValueError):
    """A line of a job file that cannot run; ``line`` is its number (from 1)."""

    def __init__(self, line: int, message: str) -> None:
        super().__init__(f"line {line}: {message}")
        self.line = line
        self.message = message


@dataclass(frozen=True)
class SurfaceSpec:
    """A job's surface as the command line names it; calling it makes the surface.

    It runs on the worker, through the same functions as ``rdmesh mesh``
    (built-in names, expressions, ``.npy`` volumes) and ``rdmesh remesh``
    (mesh files).
    """

    kind: str  # "surface", "expression", "volume" or "mesh"
    source: str  # the name, the expression or the file's path
    bound: float | None = None
    sphere: tuple | None = None
    clip_box: tuple | None = None
    volume: tuple[tuple[str, Any], ...] = ()

    def __call__(self) -> ImplicitSurface:
        from .. import _cli_surfaces as cli

        if self.kind == "mesh":
            return cli._mesh_file_surface(self.source)
        args = argparse.Namespace(
            surface=self.source,
            bound=self.bound,
            sphere=self.sphere,
            clip_box=None if self.clip_box is None else list(self.clip_box),
            features=None,
            no_features=False,
            **dict.fromkeys(VOLUME),
        )
        for key, value in self.volume:
            setattr(args, key, list(value) if isinstance(value, tuple) else value)
        return cli._surface(args)


@dataclass(frozen=True)
class JobLine:
    """A checked line of a job file."""

    line: int
    name: str
    spec: SurfaceSpec
    options: dict[str, Any] = field(default_factory=dict)
    #: A hash of everything that decides the mesh (and of the input file's size
    #: and time): a job whose line or input changed is not the job a manifest
    #: recorded.
    digest: str = ""

    def job(self, output: str) -> Job:
        """The :class:`Job` that meshes this line into ``output``."""
        return Job(self.spec, output=output, name=self.name, **self.options)


def read_jobs(path: str | os.PathLike) -> tuple[list[JobLine], list[LineError]]:
    """The jobs of the file ``path``, and the errors of its bad lines.

    Blank lines are skipped. Relative ``input`` paths are taken from the
    file's folder. A name used twice is an error on the later line.

    Raises
    ------
    OSError
        The file cannot be read.
    UnicodeDecodeError
        It is not UTF-8 text.
    """
    base = os.path.dirname(os.path.abspath(path))
    with open(path, encoding="utf-8") as lines:
        return parse_lines(lines, base)


def parse_lines(lines: Iterable[str], base: str) -> tuple[list[JobLine], list[LineError]]:
    """:func:`read_jobs` on the lines of a file in the folder ``base``."""
    jobs: list[JobLine] = []
    errors: list[LineError] = []
    first: dict[str, int] = {}
    for number, text in enumerate(lines, start=1):
        if not text.strip():
            continue
        try:
            job = parse_line(text, number, base)
            if job.name in first:
                raise LineError(
                    number, f"duplicate name {job.name!r} (first on line {first[job.name]})"
                )
        except LineError as exc:
            errors.append(exc)
            continue
        first[job.name] = number
        jobs.append(job)
    return jobs, errors


def parse_line(text: str, number: int, base: str) -> JobLine:
    """One line of a job file, checked; raises :class:`LineError`."""
    try:
        obj = json.loads(text)
    except json.JSONDecodeError as exc:
        raise LineError(number, f"invalid JSON: {exc.msg} (column {exc.colno})") from None
    if not isinstance(obj, dict):
        raise LineError(number, f"expected a JSON object, got {type(obj).__name__}")
    try:
        return _check(obj, number, base)
    except (ValueError, TypeError) as exc:
        raise LineError(number, str(exc)) from None


def _check(obj: dict[str, Any], number: int, base: str) -> JobLine:
    unknown = [k for k in obj if k not in KEYS]
    if unknown:
        raise ValueError(
            f"unknown key {unknown[0]!r}; a job has name, one of {', '.join(SOURCES)}, and "
            f"optionally {', '.join(KEYS[1 + len(SOURCES) :])}"
        )
    name = obj.get("name")
    if name is None:
        raise ValueError("missing name")
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        raise ValueError(
            f"name must be a file name of letters, digits and ._+=,@- (up to 200, not "
            f"starting with a dot or a sign), got {name!r}"
        )
    sources = [k for k in SOURCES if k in obj]
    if len(sources) != 1:
        raise ValueError(
            f"a job needs exactly one of {', '.join(SOURCES)}"
            + (f", got {' and '.join(sources)}" if sources else "")
        )
    options = {k: _OPTION_CHECKS[k](k, obj[k]) for k in MESH_OPTIONS if k in obj}
    kind = sources[0]
    if kind == "input":
        spec, stamp = _input(obj, base)
    else:
        spec, stamp = _implicit(obj, kind), None
    identity = {"spec": _plain(spec), "options": options, "input": stamp}
    digest = hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()[:16]
    return JobLine(number, name, spec, options, digest)


def _implicit(obj: dict[str, Any], kind: str) -> SurfaceSpec:
    """An expression or a built-in surface, with its sphere and clip box."""
    from ..surfaces import SURFACES
    from ..surfaces.expressions import parse_expression

    volume = [k for k in VOLUME if k in obj]
    if volume:
        raise ValueError(f"{volume[0]} applies only to volumes (an input ending in .npy)")
    if "bound" in obj and "sphere" in obj:
        raise ValueError("give bound or sphere, not both")
    text = _text(kind, obj[kind])
    bound = _positive("bound", obj["bound"]) if "bound" in obj else None
    sphere = _sphere(obj["sphere"]) if "sphere" in obj else None
    box = _box(obj["clip_box"]) if "clip_box" in obj else None
    if kind == "surface":
        key = text.strip().lower().replace("-", "_").replace(" ", "_")
        if key not in SURFACES:
            raise ValueError(
                f"unknown surface {text!r}; built-in surfaces are {', '.join(SURFACES)} "
                "(give an expression as 'expression')"
            )
        return SurfaceSpec("surface", key, bound, sphere, box)
    parse_expression(text)  # an ExpressionError (a ValueError) names what is wrong
    if bound is None and sphere is None and box is None:
        raise ValueError("an expression needs a bounding sphere: give bound, sphere or clip_box")
    return SurfaceSpec("expression", text, bound, sphere, box)


def _input(obj: dict[str, Any], base: str) -> tuple[SurfaceSpec, list[int]]:
    """A mesh file to remesh or a .npy volume, with its size and time."""
    path = _text("input", obj["input"])
    placed = [k for k in PLACEMENT if k in obj]
    if placed:
        raise ValueError(f"{placed[0]} does not apply to an input file: its extent bounds it")
    full = os.path.normpath(os.path.join(base, os.path.expanduser(path)))
    if not os.path.isfile(full):
        raise ValueError(f"input {path!r}: no such file ({full})")
    info = os.stat(full)
    stamp = [info.st_size, info.st_mtime_ns]
    if not full.lower().endswith(".npy"):
        if "method" in obj:
            raise ValueError("method does not apply to a mesh file (as in rdmesh remesh)")
        volume = [k for k in VOLUME if k in obj]
        if volume:
            raise ValueError(f"{volume[0]} applies only to volumes (an input ending in .npy)")
        return SurfaceSpec("mesh", full), stamp
    settings = tuple((k, _VOLUME_CHECKS[k](k, obj[k])) for k in VOLUME if k in obj)
    return SurfaceSpec("volume", full, volume=settings), stamp


def _plain(spec: SurfaceSpec) -> dict[str, Any]:
    return {
        "kind": spec.kind,
        "source": spec.source,
        "bound": spec.bound,
        "sphere": spec.sphere,
        "clip_box": spec.clip_box,
        "volume": [list(kv) for kv in spec.volume],
    }


# -- values -----------------------------------------------------------------------------


def _text(key: str, value: Any) -> str:
    if not isinstance(value, str) or not value.strip():
        raise ValueError(f"{key} must be a non-empty string, got {value!r}")
    return value


def _number(key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"{key} must be a finite number, got {value!r}")
    return float(value)


def _positive(key: str, value: Any) -> float:
    v = _number(key, value)
    if v <= 0:
        raise ValueError(f"{key} must be positive, got {value!r}")
    return v


def _angle(key: str, value: Any) -> float:
    v = _number(key, value)
    if not 0 <= v <= 30:
        raise ValueError(f"{key} must be between 0 and 30 degrees, got {value!r}")
    return v


def _integer(key: str, value: Any, lo: int | None = None) -> int:
    whole = isinstance(value, int) or (isinstance(value, float) and value.is_integer())
    if isinstance(value, bool) or not whole or (lo is not None and value < lo):
        what = "an integer" if lo is None else f"an integer of at least {lo}"
        raise ValueError(f"{key} must be {what}, got {value!r}")
    return int(value)


def _choice(options: tuple[str, ...]):
    def check(key: str, value: Any) -> str:
        if value not in options:
            raise ValueError(f"{key} must be one of {', '.join(options)}, got {value!r}")
        return value

    return check


def _numbers(key: str, value: Any, n: int) -> tuple[float, ...]:
    if not isinstance(value, list) or len(value) != n:
        raise ValueError(f"{key} must be a list of {n} numbers, got {value!r}")
    return tuple(_number(key, v) for v in value)


def _sphere(value: Any) -> tuple[tuple[float, float, float], float]:
    if isinstance(value, str):
        parts = value.split(",")
        try:
            value = [float(p) for p in parts]
        except ValueError:
            value = parts
    cx, cy, cz, r = _numbers("sphere", value, 4)
    if r <= 0:
        raise ValueError(f"sphere radius must be positive, got {r!r}")
    return (cx, cy, cz), r


def _box(value: Any) -> tuple[float, ...]:
    box = _numbers("clip_box", value, 6)
    flat = [axis for axis, a, b in zip("xyz", box[:3], box[3:], strict=True) if not a < b]
    if flat:
        raise ValueError(
            f"clip_box [x0, y0, z0, x1, y1, z1] needs x0 < x1, y0 < y1 and z0 < z1; not on "
            f"{', '.join(flat)}"
        )
    return box


def _three(positive: bool):
    def check(key: str, value: Any) -> tuple[float, ...]:
        values = _numbers(key, value, 3)
        if positive and min(values) <= 0:
            raise ValueError(f"{key} must be 3 positive numbers, got {value!r}")
        return values

    return check


def _option_checks() -> dict[str, Any]:
    from ..refine.methods import METHODS, TOPOLOGIES

    return {
        "angle_bound": _angle,
        "radius_bound": _positive,
        "distance_bound": _positive,
        "method": _choice(tuple(METHODS)),
        "topology": _choice(tuple(TOPOLOGIES)),
        "time_limit": _positive,
        "max_vertices": lambda k, v: _integer(k, v, lo=1),
        "seed": _integer,
        "edge_size": _positive,
    }


def _volume_checks() -> dict[str, Any]:
    from ..surfaces.volume import BORDERS, INSIDE, INTERPOLATIONS

    return {
        "isovalue": _number,
        "spacing": _three(positive=True),
        "origin": _three(positive=False),
        "inside": _choice(tuple(INSIDE)),
        "interpolation": _choice(tuple(INTERPOLATIONS)),
        "border": _choice(tuple(BORDERS)),
    }


_OPTION_CHECKS = _option_checks()
_VOLUME_CHECKS = _volume_checks()
