"""A sphinx-gallery image scraper for the PNG files an example writes.

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
