"""Write docs/volume-phantom.png, the README's picture of a meshed volume.

The CT-like phantom of ``tests/volumes.py`` (96 x 96 x 64 samples), its bone
isosurface meshed by rdmesh and drawn with ``SurfaceMesh.render``::

    python scripts/volume_picture.py [OUT.png]
"""

from __future__ import annotations

import itertools
import sys
from pathlib import Path

import numpy as np
import rdmesh
from rdmesh.io.render import render

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

import volumes  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    out = argv[0] if argv else str(ROOT / "docs" / "volume-phantom.png")
    vol, spacing = volumes.phantom((96, 96, 64), spacing=(0.5, 0.5, 0.75))
    surface = rdmesh.VolumeSurface(vol, spacing=spacing, isovalue=volumes.BONE_ISOVALUE)
    mesh = rdmesh.mesh_surface(surface, radius_bound=surface.radius / 80)
    topo = mesh.topology()
    title = (
        f"{len(mesh.vertices)} vertices, min angle {mesh.min_angle:.1f} deg, genus "
        f"{', '.join(f'{g:g}' for g in sorted(topo['genus'], reverse=True))}"
    )
    render_framed(mesh, out, title)
    print(f"wrote {out}: {title}")
    return 0


def render_framed(mesh: rdmesh.SurfaceMesh, out: str, title: str, size: int = 720) -> None:
    """Draw ``mesh`` framed by its box enlarged by 10% on each side.

    The renderer zooms in on the faces' box and would cut the corners off; the
    frame's 8 corners are added as invisible zero-area faces.
    """
    lo, hi = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    lo, hi = lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo)
    corners = lo + np.array(list(itertools.product((0, 1), repeat=3))) * (hi - lo)
    vertices = np.concatenate([mesh.vertices, corners])
    dots = len(mesh.vertices) + np.repeat(np.arange(8), 3).reshape(8, 3)
    render(vertices, np.concatenate([mesh.faces, dots]), out, title=title, size=size)


if __name__ == "__main__":
    sys.exit(main())
