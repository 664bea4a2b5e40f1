"""Sphinx configuration of the tde-twin documentation (``make docs``).

Built offline with warnings treated as errors (``-W``): Markdown pages through MyST, the API
reference generated from the NumPy docstrings (autosummary + numpydoc), tutorials and gallery
examples executed at build time by sphinx-gallery, the performance page rendered from the
benchmarks' JSON (``benchmarks/results``) by ``docs/performance_page.py``.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # headless build: the examples' figures are scraped from Agg canvases

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(DOCS))

import twin  # noqa: E402
from performance_page import write_performance_page, write_plan_results  # noqa: E402

project = "tde-twin"
author = "tde-twin developers"
copyright = "2026, tde-twin developers"
release = version = twin.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "notebooks", "tutorials/README.txt", "gallery/README.txt",
                    "**.ipynb_checkpoints", "plan_results.md"]
templates_path = ["_templates"]

# ---------------------------------------------------------------- Markdown (MyST)
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3

# ---------------------------------------------------------------- API reference
autosummary_generate = True
autosummary_imported_members = False
# a package page documents what the package itself defines: its __all__ re-exports names (e.g. the
# function twin.calibration.validate) that are also module pages, which Sphinx calls duplicates
autodoc_default_options = {"members": True, "show-inheritance": False, "ignore-module-all": True}
autodoc_typehints = "none"  # numpydoc's Parameters section carries the types and units
autodoc_mock_imports: list[str] = []
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()

# ---------------------------------------------------------------- tutorials and gallery
sphinx_gallery_conf = {
    "examples_dirs": ["tutorials", "gallery"],
    "gallery_dirs": ["auto_tutorials", "auto_gallery"],
    "filename_pattern": r"/(plot_|tutorial_)",  # every script is executed at build time
    "within_subsection_order": "FileNameSortKey",
    "matplotlib_animations": False,
    "remove_config_comments": True,
    "download_all_examples": False,
    "abort_on_example_error": True,
    "only_warn_on_example_error": False,
    "show_memory": False,
    "reset_modules": ("matplotlib",),
}
# the tutorials read the real logs kept beside the project; `make docs` sets TWIN_REAL_DATA
os.environ.setdefault("MPLBACKEND", "Agg")

# ---------------------------------------------------------------- HTML
html_theme = "furo"
html_title = f"tde-twin {release}"
html_static_path: list[str] = []
html_show_sourcelink = False

nitpicky = False
suppress_warnings = ["config.cache"]  # sphinx_gallery_conf holds a function: not picklable


def _plain_text_bars(app, what, name, obj, options, lines):
    """Our docstrings are plain text where ``|x|`` is a magnitude; reST would read it as a
    substitution reference. Escape every bar outside code spans and doctest lines."""
    for i, line in enumerate(lines):
        if "|" in line and not line.lstrip().startswith((">>>", "...")):
            parts = line.split("``")  # odd parts are inside ``code``
            lines[i] = "``".join(p if k % 2 else p.replace("|", r"\|") for k, p in enumerate(parts))


def _skip_generated_members(app, what, name, obj, skip, options):
    """scikit-learn generates ``set_*_request`` methods on every estimator (metadata routing);
    their docstrings cite scikit-learn's own glossary, which this site does not have."""
    if name.startswith("set_") and name.endswith("_request"):
        return True
    return None


def setup(app):
    """Render the performance page from the benchmarks' JSON before the sources are read."""
    write_performance_page(ROOT / "benchmarks" / "results", DOCS / "performance.md")
    write_plan_results(ROOT / "benchmarks" / "results" / "bench_plan.json", DOCS / "plan_results.md")
    app.connect("autodoc-process-docstring", _plain_text_bars)
    app.connect("autodoc-skip-member", _skip_generated_members)
