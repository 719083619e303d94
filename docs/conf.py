"""Sphinx configuration of the pfmpm documentation site (built by tools/docs.sh).

The API pages (docs/api) document the pfmpm that the Python running Sphinx
imports: .venv's, installed from src/ by tools/setup.sh.
"""

project = "pfmpm"

extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.napoleon"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}

# Anchors for the Markdown headings down to ###, the targets of links such as
# method.md#time-step.
myst_heading_anchors = 3

# Members in the order of each module's __all__, or of its source.
autodoc_member_order = "bysource"
# The docstrings are numpy-style only: a line such as "Note:" is not a Google section.
napoleon_google_docstring = False


def whole_first_line(app, what, name, obj, options, lines):
    """Napoleon reads an attribute's docstring up to its first colon as the
    attribute's type ("int: the count"), a form no docstring here uses, while
    many first lines hold a colon ("Extra columns: ..."). An empty type in
    front keeps the line whole."""
    if what in ("attribute", "data", "property") and lines:
        lines[0] = ": " + lines[0]


def setup(app):
    # Before napoleon's handler (priority 500).
    app.connect("autodoc-process-docstring", whole_first_line, priority=400)
