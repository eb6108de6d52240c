"""The gallery's helpers: an image scraper for the PNG files an example writes,
and the order of the examples.

The gallery's examples draw with rdmesh's own renderer,
``mesh.render("name.png")``, which writes a file instead of opening a pyplot
figure. sphinx-gallery runs each example in its own folder (``examples/``);
after every code block this scraper moves the PNG files that block wrote into
the gallery's image folder, in the order they were written, and returns the
reST that shows them. Nothing is left behind in ``examples/``.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from sphinx_gallery.scrapers import figure_rst


def png_scraper(block, block_vars, gallery_conf, **kwargs):
    """Move the PNG files written by this block next to the gallery's images."""
    folder = Path(block_vars["src_file"]).parent
    written = sorted(folder.glob("*.png"), key=lambda p: (p.stat().st_mtime_ns, p.name))
    if not written:
        return ""
    image_paths = []
    for png in written:
        target = block_vars["image_path_iterator"].next()
        shutil.move(str(png), target)
        image_paths.append(target)
    return figure_rst(image_paths, gallery_conf["src_dir"])


def _get_sg_image_scraper():
    return png_scraper


#: The gallery's order: from the first mesh to the batch. Examples not listed
#: come after these, by file name.
ORDER = (
    "plot_torus.py",
    "plot_certified_expression.py",
    "plot_volume_marching_cubes.py",
    "plot_remesh.py",
    "plot_clipped_gyroid.py",
    "plot_creases.py",
    "plot_found_creases.py",
    "plot_batch.py",
)


class ExampleOrder:
    """sphinx-gallery's ``within_subsection_order``: :data:`ORDER`, then by name."""

    def __init__(self, src_dir: str) -> None:
        self.src_dir = src_dir

    def __call__(self, filename: str) -> tuple[int, str]:
        rank = ORDER.index(filename) if filename in ORDER else len(ORDER)
        return rank, filename

    def __repr__(self) -> str:
        return f"<{self.__class__.__name__}: {', '.join(ORDER)}>"
