"""Sphinx configuration: the docs/*.md pages (MyST) and the API reference from the docstrings.

Build with ``python -m sphinx -W -b html docs docs/_build/html`` (``pip install '.[docs]'``).
"""

import re
import sys
from pathlib import Path

# document the sources beside this folder (also without installing the package)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import mechrel  # noqa: E402

project = "mechrel"
author = "mechrel developers"
copyright = "2026, mechrel developers"  # noqa: A001 (Sphinx's name)
release = mechrel.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "figures/**/*.md"]

myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 4
suppress_warnings = ["myst.xref_missing"]

autodoc_member_order = "bysource"
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()

html_theme = "alabaster"
html_title = f"mechrel {release}"

# The docstrings write absolute values and norms as plain text, |e| or |v_T| (as the Markdown
# pages do); reStructuredText would read |e| as a substitution reference. Escape those bars,
# except in literals, roles and math blocks (where |x| is LaTeX's absolute value).
_LITERAL = re.compile(r"(``.+?``|:\w+:`[^`]+`|`[^`]+`_?)")


def _escape_bars(app, what, name, obj, options, lines):
    in_math, math_indent = False, 0
    for i, line in enumerate(lines):
        stripped = line.lstrip()
        indent = len(line) - len(stripped)
        if in_math and stripped and indent <= math_indent:
            in_math = False
        if stripped.startswith(".. math::"):
            in_math, math_indent = True, indent
            continue
        # a line block or a grid-table row starts with "| " or "+"; a line that starts with an
        # absolute value (|e| ...) is prose and gets escaped like any other
        if in_math or "|" not in line or stripped.startswith(("| ", "+")) or stripped == "|":
            continue
        parts = _LITERAL.split(line)
        lines[i] = "".join(p if k % 2 else p.replace("|", r"\|") for k, p in enumerate(parts))


def setup(app):
    app.connect("autodoc-process-docstring", _escape_bars, priority=400)
