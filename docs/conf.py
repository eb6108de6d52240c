"""Sphinx configuration of the rdmesh documentation.

Build with ``bash scripts/quickstart.sh docs`` (warnings are errors), or by hand::

    .venv/bin/python -m sphinx -W --keep-going -b html docs docs/_build/html

The API reference is read from the installed ``rdmesh`` (numpydoc); the
gallery runs every ``examples/plot_*.py`` (sphinx-gallery) and keeps the
pictures each one writes with :meth:`rdmesh.SurfaceMesh.render`.
"""

import os
import sys

import rdmesh

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "_ext"))

project = "rdmesh"
author = "the rdmesh developers"
copyright = "the rdmesh developers; GPL-3.0-or-later"  # noqa: A001
release = rdmesh.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.graphviz",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_ext", "**.ipynb_checkpoints", "auto_examples/*.py"]
templates_path = []

# -- MyST (the prose pages are Markdown, so they read on GitHub too) ----------
myst_enable_extensions = ["colon_fence", "deflist"]
# Links like [text](guarantees.md#what-is-proven) resolve to section anchors.
myst_heading_anchors = 4

# -- API reference (numpydoc over autodoc) ------------------------------------
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": True}
autodoc_typehints = "none"  # numpydoc's Parameters sections carry the types
autosummary_generate = False
numpydoc_show_class_members = False
numpydoc_xref_param_type = False
numpydoc_validation_checks = set()

# -- Diagram (Debian's graphviz provides `dot`) --------------------------------
graphviz_output_format = "svg"

# -- Gallery ------------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": "../examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",  # run every plot_*.py during the build
    "ignore_pattern": r"__init__\.py",
    # Pictures come from SurfaceMesh.render (PNG files), plus any pyplot figure.
    "image_scrapers": ("matplotlib", "rdmesh_gallery.png_scraper"),
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "rdmesh_gallery.ExampleOrder",
    "show_memory": False,
    "abort_on_example_error": True,
    "only_warn_on_example_error": False,
}

# -- HTML ---------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"rdmesh {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_show_sourcelink = False
# Pages without sub-pages need no left sidebar (it would be empty).
html_sidebars = {
    page: []
    for page in (
        "index",
        "install",
        "quickstart",
        "guarantees",
        "api",
        "how-it-works",
        "performance",
        "contributing",
    )
}
