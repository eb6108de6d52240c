# SPDX-License-Identifier: GPL-3.0-or-later
"""The suite's inputs besides the built-in implicit surfaces: what they share.

An *input* is a kind of thing users bring (issue 15): a volume
(``input_volume.py``), a triangle mesh to remesh (``input_remesh.py``) or a
surface clipped by its domain, a sphere or a box (``input_clipped.py``).  Each has named cases,
the meshers that run on it and, for one case at one target vertex count:

- ``params(case, size)`` (parent side): what every mesher gets, cheap;
- ``run(mesher, spec)`` (child side, a fresh process): build the input (not
  timed), time the meshing call alone, write the mesh to ``spec["out"]``
  and return the run's fields (seconds, vertices, faces, evaluations,
  baseline_rss_mb, extra; the "input" row of remeshing, which meshes
  nothing, also sets ``peak_rss_mb`` to None);
- ``quality(case, params, vertices, faces, reference_samples=, seed=, angle=)``
  (parent side): the case's ``quality`` entry, in the same format as the
  implicit surfaces' (``quality.QualityMeter``): angles, topology,
  Hausdorff distance to the input's own reference.

This module holds the registry (:func:`kind`), the adapter that runs an
input's Python mesher through ``meshers.py`` (:class:`InputMesher`), the
child side's dispatch (:func:`child_run`) and the quality entry's assembly
(:func:`quality_entry`).
"""

from __future__ import annotations

import argparse
import importlib
import json
from typing import Any

from meshers import CHILD, PythonMesher
from record import jsonable

__all__ = [
    "INPUTS",
    "VERTICES_PER_AREA",
    "InputKind",
    "InputMesher",
    "child_run",
    "kind",
    "quality_entry",
]

#: The inputs, in the order the suite runs them; "implicit" is the built-in
#: surfaces (``suite.py``'s original rows).
INPUTS = ("implicit", "volume", "remesh", "clipped", "clipped_box")
_MODULES = {
    "volume": "input_volume",
    "remesh": "input_remesh",
    "clipped": "input_clipped",
    "clipped_box": "input_clipped",
}
#: The module attribute that holds each input (default ``INPUT``).
_ATTRIBUTES = {"clipped_box": "BOX_INPUT"}
#: rdmesh gives about ``C * area / r^2`` vertices at radius bound r; C as
#: calibrated on the built-in surfaces (0.67-0.74, ``calibration.py``).  The
#: inputs use it to aim rdmesh at a target vertex count without a
#: calibration run of their own.
VERTICES_PER_AREA = 0.7


class InputKind:
    """One kind of input: its cases and meshers (subclasses fill them in)."""

    name = ""
    #: Meshers run on every case, in the suite's order.
    meshers: tuple[str, ...] = ()
    #: How the report names each mesher.
    labels: dict[str, str] = {}

    def cases(self) -> tuple[str, ...]:
        """The case names (unique across inputs: they are the suite's "surface")."""
        raise NotImplementedError

    def check(self, mesher: str) -> str | None:
        """Why ``mesher`` cannot run here (None: it can)."""
        return None

    def adapter(self, mesher: str, record: dict, log) -> tuple[Any, str | None]:
        """The suite's adapter of ``mesher`` (a ``meshers.Mesher``), and why it
        cannot run (None: it can).  Python meshers run through ``meshers.py``."""
        return InputMesher(mesher, self.name), self.check(mesher)

    def params(self, case: str, size: int) -> dict[str, Any]:
        """What every mesher gets for ``case`` at about ``size`` vertices."""
        raise NotImplementedError

    def run(self, mesher: str, spec: dict) -> dict[str, Any]:
        """One timed run in the child process (see the module notes)."""
        raise NotImplementedError

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
        """The quality entry of a mesh of ``case`` (see :func:`quality_entry`).

        ``reference_samples`` points on the input's reference surface, random
        mesh samples drawn with ``seed``, angles counted against ``angle``.
        """
        raise NotImplementedError


def kind(name: str) -> InputKind:
    """The input called ``name`` ("volume", "remesh", "clipped" or "clipped_box").

    Raises
    ------
    KeyError
        For "implicit" or an unknown name.
    """
    return getattr(importlib.import_module(_MODULES[name]), _ATTRIBUTES.get(name, "INPUT"))


def quality_entry(
    vertices,
    faces,
    hausdorff: dict[str, Any] | None,
    angle: float,
    expected: dict[str, Any],
    **extra: Any,
) -> dict[str, Any]:
    """A case's ``quality`` entry: the suite's fields, for any input.

    Parameters
    ----------
    vertices, faces : (V, 3) float array, (F, 3) int array
        The mesh (unused vertices already dropped).
    hausdorff : dict or None
        As ``metrics.hausdorff`` returns it: ``two_sided``,
        ``mesh_to_surface`` and ``surface_to_mesh`` (each with ``max``),
        ``vertex_to_surface_max``.
    angle : float
        The angle bound the angle statistics count against (degrees).
    expected : dict
        Keywords of ``metrics.topology_stats``: ``expected_components``,
        ``expected_euler`` and optionally ``expected_loops`` and
        ``expected_per_component``.
    **extra
        More fields (for example ``boundary_offset``).

    Returns
    -------
    dict
        ``vertices``, ``faces``, the fields of ``metrics.angle_stats``,
        ``topology``, ``area``, ``hausdorff`` and ``extra``'s.
    """
    from metrics import angle_stats, mesh_area, topology_stats

    q: dict[str, Any] = {"vertices": int(len(vertices)), "faces": int(len(faces))}
    q.update(angle_stats(vertices, faces, angle))
    q["topology"] = topology_stats(vertices, faces, **expected)
    q["area"] = mesh_area(vertices, faces) if len(faces) else 0.0
    q["hausdorff"] = hausdorff
    q.update(extra)
    return q


class InputMesher(PythonMesher):
    """A Python mesher of an input, run by ``meshers.py`` in a fresh process."""

    def __init__(self, name: str, input_name: str) -> None:
        super().__init__(name)
        self.input = input_name

    def command(self, case: dict, args: argparse.Namespace, mesh_path: str | None) -> list[str]:
        spec = {
            "input": self.input,
            "mesher": self.name,
            "case": case["surface"],
            "size": case["size"],
            "out": mesh_path,
            "angle": args.angle,
            "seed": args.seed,
            **case["params"],
        }
        return [self.python(args), str(CHILD), json.dumps(spec)]


def child_run(spec: dict) -> int:
    """The child side of an input's run: print the run's fields as one JSON line."""
    result = kind(spec["input"]).run(spec["mesher"], spec)
    print(json.dumps(jsonable(result)))
    return 0
