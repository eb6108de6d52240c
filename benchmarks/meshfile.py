# SPDX-License-Identifier: GPL-3.0-or-later
"""The mesh files a run leaves for the quality measurement.

The Python meshers write ``.npz`` (``vertices``, ``faces``), the CGAL
reference program writes OFF.
"""

from __future__ import annotations

import os

__all__ = ["load_mesh", "mesh_run", "read_off", "save_mesh"]


def save_mesh(path: str | None, vertices, faces) -> None:
    """Write ``vertices`` (V, 3) and ``faces`` (F, 3) to ``path`` (.npz); None: nothing."""
    if path:
        import numpy as np

        np.savez(path, vertices=np.asarray(vertices, float), faces=np.asarray(faces, np.int64))


def mesh_run(
    path: str | None,
    vertices,
    faces,
    *,
    seconds: float,
    evaluations: int,
    baseline_rss_mb: float,
    extra: dict,
) -> dict:
    """Write the mesh (:func:`save_mesh`) and return a child's run record: time,
    vertices in faces, faces, evaluations of f, the RSS before meshing, extra."""
    import numpy as np

    save_mesh(path, vertices, faces)
    return {
        "seconds": seconds,
        "vertices": int(len(np.unique(faces))),
        "faces": int(len(faces)),
        "evaluations": int(evaluations),
        "baseline_rss_mb": baseline_rss_mb,
        "extra": extra,
    }


def read_off(path: str | os.PathLike) -> tuple:
    """Vertices and triangles of an OFF file (as written by the CGAL reference)."""
    import numpy as np

    with open(path) as fh:
        text = fh.read()
    lines = text.split("\n")
    i = 0
    header: list[str] = []
    # The "OFF" keyword and the counts, skipping comments and blank lines.
    while len(header) < 4 and i < len(lines):
        ln = lines[i].split("#", 1)[0].strip()
        i += 1
        if ln:
            header += ln.split()
    if not header or header[0] != "OFF":
        raise ValueError(f"{path}: not an OFF file")
    nv, nf = int(header[1]), int(header[2])
    data = np.array("\n".join(lines[i:]).split(), dtype=np.float64)
    vertices = data[: 3 * nv].reshape(nv, 3)
    rest = data[3 * nv : 3 * nv + 4 * nf].reshape(nf, 4)
    if nf and not np.all(rest[:, 0] == 3):
        raise ValueError(f"{path}: only triangle faces are supported")
    return vertices, rest[:, 1:].astype(np.int64)


def load_mesh(path: str | os.PathLike) -> tuple:
    """Vertices and faces of a mesh file written by a run (.off or .npz)."""
    import numpy as np

    path = str(path)
    if path.endswith(".off"):
        return read_off(path)
    with np.load(path) as z:
        return z["vertices"], z["faces"]
