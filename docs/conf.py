"""Sphinx configuration of latdyn's documentation (issue 35 item 2).

Build:  python -m sphinx -W -b html docs OUT   (warnings are errors)

The Markdown pages of docs/ are read by myst-parser; the gallery (examples/gallery/plot_*.py) is
executed by sphinx-gallery at every build; the scene reference and the verification manual are
written at every build by docs/_ext/ from the loader's own tables and from validation runs, so
neither can go stale.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))           # the checkout's latdyn, codegen and benchmarks
sys.path.insert(0, str(DOCS / "_ext"))
os.environ.setdefault("MPLBACKEND", "Agg")

from latdyn import __version__  # noqa: E402

project = "latdyn"
author = "the latdyn authors"
copyright = "latdyn authors, BSD-3-Clause"
release = version = __version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
    "scene_reference",
    "verification_manual",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "_generated/*.txt", "gallery/*.ipynb", "gallery/*.py", "gallery/*.json",
                    "gallery/*.zip", "gallery/*.md5", "gallery/*.codeobj.json"]
myst_enable_extensions = ["dollarmath"]
myst_heading_anchors = 3
# docs/performance.md steps from ## to #### in two places (headings under a table's caption);
# every other warning (a broken link included) fails the build.
suppress_warnings = ["myst.header"]

autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "show-inheritance": False}

sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples" / "gallery"),
    "gallery_dirs": "gallery",
    "filename_pattern": r"/plot_",      # execute every plot_*.py
    "abort_on_example_error": True,     # a failing example (an assertion against its reference) fails the build
    "only_warn_on_example_error": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "reset_modules": ("matplotlib",),
    "show_memory": False,
    "plot_gallery": "True",
}

html_theme = "alabaster"
html_title = f"latdyn {release}"
html_static_path: list[str] = []
