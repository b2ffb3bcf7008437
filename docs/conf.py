"""Sphinx configuration of the rasc documentation site (``make docs``).

The reference pages are generated, not typed: the API from the docstrings (autosummary,
numpydoc), the commands from their argparse parsers, the file formats, study parameters,
frame tables and the refusals and warnings from the code (``docs/_ext/rasc_docs.py``).
The example gallery (``docs/gallery/``) is executed on every build (sphinx-gallery).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))            # this checkout's rasc, before an installed one
sys.path.insert(0, str(DOCS / "_ext"))
os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("MPLBACKEND", "Agg")

import rasc  # noqa: E402

project = "rasc"
author = "the rasc developers"
copyright = "2026, the rasc developers"
release = rasc.__version__
version = ".".join(release.split(".")[:2])

extensions = [
    "myst_parser",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.intersphinx",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "sphinx_gallery.gen_gallery",
    "rasc_docs",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "gallery/README.txt",
                    "auto_gallery/*.ipynb", "auto_gallery/*.py", "auto_gallery/*.zip"]
templates_path = ["_templates"]
# (a globbed toctree entry whose folder is still empty is dropped by rasc_docs; every
# other warning is an error: make docs runs sphinx-build -W)

# ---- MyST
myst_enable_extensions = ["colon_fence", "deflist", "dollarmath", "fieldlist"]
myst_heading_anchors = 3

# ---- API reference
autosummary_generate = True
autosummary_imported_members = False
# rasc/__main__.py runs the command line when imported: never import it for the listing
autosummary_mock_imports = ["rasc.__main__"]
autodoc_default_options = {"members": True}   # bases: rasc_docs._add_bases
autodoc_typehints = "none"            # numpydoc's Parameters section says the types
autodoc_member_order = "bysource"
numpydoc_show_class_members = False   # autosummary lists them
numpydoc_class_members_toctree = False
numpydoc_validation_checks: set[str] = set()
numpydoc_xref_param_type = False

intersphinx_mapping: dict[str, tuple[str, str | None]] = {}   # the build reads no network

# ---- executed example gallery: synthetic data only, seconds each
sphinx_gallery_conf = {
    "examples_dirs": "gallery",
    "gallery_dirs": "auto_gallery",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "show_memory": False,
    "plot_gallery": "True",
    "abort_on_example_error": True,
}

# ---- HTML
html_theme = "pydata_sphinx_theme"
html_title = f"rasc {release}"
html_static_path = ["_static"]
html_css_files = ["rasc.css"]
html_show_sourcelink = False
# The guide pages and the project pages stand directly under the front page, so the theme's
# section navigation would be empty on them: leave the left sidebar out there.
html_sidebars = {"guide/*": [], "changelog": [], "METHOD": [], "CONTRACTS": [], "NOTES": []}
html_theme_options = {
    "navigation_with_keys": False,
    "header_links_before_dropdown": 4,
    "navbar_align": "left",
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version", "theme-version"],
}
