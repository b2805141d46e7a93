"""Sphinx configuration of the geogait documentation site (``make docs``)."""

import sys
from pathlib import Path

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE / "_ext"))

project = "geogait"
author = "geogait contributors"
copyright = "geogait contributors"

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "geogait_api",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
# (the manifests' folder holds tables the results pages link as files, not pages of their own)
exclude_patterns = ["_build", "_ext", "results/optimizer-robots/**"]
# (a page may step from a title straight to level-3 headings: it renders the same)
suppress_warnings = ["myst.header"]

#: Titles of the pages that benchmarks/robots.py writes as a bare table (it is also read on GitHub, where the
#: folder names it): the site puts the title above it.
TABLE_TITLES = {
    "results/robots/robots": "Robot benchmark: every case and method",
    "results/robots-elastica/robots": "Robot benchmark: the continuum snake",
    "results/change-benchmark/robots": "Change benchmark: every method",
    "results/change-benchmark-gp/robots": "Change benchmark: the Gaussian-process optimiser",
    "results/change-benchmark-robots/robots": "Change benchmark: robots geogait did not write",
    "results/change-benchmark-elastica/robots": "Change benchmark: the continuum snake",
    "results/undeclared/robots": "Robots that declare nothing: every run",
}


def _title_tables(app, docname, source):
    if docname in TABLE_TITLES:
        source[0] = f"# {TABLE_TITLES[docname]}\n\n{source[0]}"


def setup(app):
    app.connect("source-read", _title_tables)

# -- the API reference: numpydoc docstrings, Sphinx roles rendered ----------------------------------------------
autosummary_generate = False  # (geogait_api writes the pages, from each module's __all__)
autodoc_typehints = "none"  # the docstrings' numpydoc types say it; signatures stay short
autodoc_member_order = "bysource"
autodoc_default_options = {"exclude-members": "__init__, __new__"}
numpydoc_show_class_members = False  # (members are documented by autodoc below the class)
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
default_role = "py:obj"  # `name` in a docstring links to the object
nitpicky = False

# -- markdown pages --------------------------------------------------------------------------------------------
myst_heading_anchors = 4  # [text](page.md#a-heading) as GitHub writes the anchor
myst_enable_extensions = ["colon_fence", "deflist"]

# -- the examples gallery --------------------------------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": str(HERE.parent / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",  # run in the build: each takes seconds
    "ignore_pattern": r"^(?!.*plot_)",  # the long studies (mujoco_*, elastica_*, robot_stream) and templates
    "download_all_examples": False,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "min_reported_time": 1,
    "show_memory": False,
    "reference_url": {"geogait": None},
    "within_subsection_order": "FileNameSortKey",
}

# -- HTML ------------------------------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = "geogait"
html_static_path = ["_static"]
html_css_files = ["geogait.css"]
html_theme_options = {
    "navbar_align": "left",
    "show_toc_level": 2,
    "header_links_before_dropdown": 7,
    # the results pages' wide tables get the width of the page-contents column
    "secondary_sidebar_items": {pattern: ["page-toc"] for pattern in
                                ("*", "tutorials/*", "how-to/*", "explanations/*", "auto_examples/*", "api/**")},
    "footer_start": [],
    "footer_end": [],
}
html_show_sourcelink = False
html_copy_source = False
