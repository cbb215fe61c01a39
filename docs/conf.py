"""Sphinx configuration: ``sphinx-build -W --keep-going -b html docs docs/_build/html``."""

import os
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))
os.environ.setdefault("MPLBACKEND", "Agg")

import sparseedm  # noqa: E402
from reference import constants, defined_in, write_api_pages  # noqa: E402

project = "sparseedm"
author = "sparseedm developers"
copyright = "sparseedm developers"
release = version = sparseedm.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "rundocs",
    "reference",
    "results",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "tutorials/README.rst", "**/sg_execution_times.rst"]
templates_path = ["_templates"]
html_theme = "furo"
html_title = f"sparseedm {release}"
html_static_path = []
myst_heading_anchors = 3
myst_enable_extensions = ["colon_fence"]
suppress_warnings = ["myst.header"]
smartquotes = False  # commands keep their "--" and quotes

# ---- API reference: one page per public module, from its __all__ ------------
API_MODULES = write_api_pages(HERE / "reference" / "api")
autosummary_generate = True
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
# what every public docstring must have: a summary, its parameters and what it returns
numpydoc_validation_checks = {"GL08", "PR01", "PR02", "RT01", "SS01"}
# modules being edited by others right now: validated once their edits land
NOT_YET_VALIDATED = []
numpydoc_validation_exclude = set(defined_in(NOT_YET_VALIDATED)) | {
    r"\.__init__$", r"\.__call__$", r"\.__repr__$",
} | {rf"^{re.escape(name)}$" for name in constants(API_MODULES)}  # a constant's doc is its type's

# ---- tutorials: scripts executed at build time ------------------------------
sphinx_gallery_conf = {
    "examples_dirs": "tutorials",
    "gallery_dirs": "auto_tutorials",
    "filename_pattern": r"\.py$",
    "ignore_pattern": r"_workdir\.py$",  # the tutorials' shared helper, not a tutorial
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "show_memory": False,
    "min_reported_time": 1e9,
    "write_computation_times": False,
    "reset_modules": ("matplotlib",),
}
