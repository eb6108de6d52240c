"""Feature curves in CGAL's polylines text format: one polyline per line,
``n x1 y1 z1 ... xn yn zn`` (the format of Mesh_3's examples and
``benchmarks/cgal_runner.write_polylines``)."""

from __future__ import annotations

import os

import numpy as np

from .graph import FeatureError


def read_polylines(path: str | os.PathLike) -> list[np.ndarray]:
    """The polylines of a file, each an ``(n, 3)`` array.

    Raises
    ------
    FeatureError
        A line that is not ``n`` followed by ``3 n`` numbers (the message
        names the line); OSError when the file cannot be read.
    """
    out = []
    with open(path, encoding="utf-8") as fh:
        for k, line in enumerate(fh, start=1):
            words = line.split()
            if not words or words[0].startswith("#"):
                continue
            try:
                n = int(words[0])
                values = np.array([float(w) for w in words[1:]])
            except ValueError:
                raise FeatureError(
                    f"{os.fspath(path)} line {k}: expected a count n and 3 n numbers"
                ) from None
            if n < 1 or len(values) != 3 * n:
                raise FeatureError(
                    f"{os.fspath(path)} line {k}: a polyline of {n} points needs {3 * n} "
                    f"numbers after the count, got {len(values)}"
                )
            out.append(values.reshape(n, 3))
    if not out:
        raise FeatureError(f"{os.fspath(path)} holds no polyline")
    return out
