"""Sphinx configuration of the tmaplan documentation (``make docs``).

Generated at build time, never committed (all under ``docs/_generated/`` or the build folder):

* the API reference: ``autosummary`` recursive over the :mod:`tmaplan` package, so that new or
  moved modules appear without editing these pages;
* the user guide: the notebooks of ``notebooks/`` executed and rendered with myst-nb
  (``nb_execution_mode = "cache"``: a notebook runs again only when it changes);
* the scenario-file reference: the ``scenario-reference`` directive of
  ``_ext/scenario_reference.py`` reads the scenario dataclasses of :mod:`tmaplan.scenario`;
* the CLI reference: sphinx-argparse over the parser of :mod:`tmaplan.cli`.
"""

from __future__ import annotations

import os
import re
import shutil
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(DOCS / "_ext"))

import sphinx.ext.autosummary  # noqa: E402

import tmaplan  # noqa: E402

project = "tmaplan"
author = "tmaplan developers"
copyright = "2026, tmaplan developers"
release = tmaplan.__version__
version = ".".join(release.split(".")[:2])

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_nb",
    "sphinxarg.ext",
    "scenario_reference",
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "**.ipynb_checkpoints"]
templates_path = ["_templates"]

# -- API reference ----------------------------------------------------------------------------
autosummary_generate = True
# ``python -m`` entry points run the CLI only as __main__; mocked as well, to be safe
autodoc_mock_imports = ["tmaplan.cli.__main__"]
autosummary_imported_members = False
autosummary_ignore_module_all = True  # each module documents the public names it defines
autodoc_typehints = "none"  # numpydoc docstrings carry the types and units
# members are documented on their own autosummary pages (templates in _templates/)
autodoc_default_options: dict[str, bool] = {}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False


_ABS_BARS = re.compile(r"(?<![|\\\w`])\|(?=[^\s|`])([^|`\n]*?[^\s|`\\])?\|(?![|\w`])")


def _escape_absolute_values(app, what, name, obj, options, lines):
    """Docstrings write absolute values and norms as ``|x|``; reST would read a substitution."""
    for i, line in enumerate(lines):
        lines[i] = _ABS_BARS.sub(lambda m: "\\|" + (m.group(1) or "") + "\\|", line)


def _first_paragraph_if_cut(extract):
    """Sphinx cuts an autosummary summary at ". " even inside an inline literal (``a,b,..``)
    and then checks the wrong text for broken markup; keep the whole first paragraph then."""

    def summary(doc, settings):
        text = extract(doc, settings)
        if text.count("``") % 2 == 0:
            return text
        lines = []
        for line in doc:
            if not line.strip():
                if lines:
                    break
                continue
            lines.append(line.strip())
        return " ".join(lines)

    return summary


sphinx.ext.autosummary.extract_summary = _first_paragraph_if_cut(
    sphinx.ext.autosummary.extract_summary)


def setup(app):
    """Connect the docstring hook (before numpydoc, which runs at priority 500)."""
    app.connect("autodoc-process-docstring", _escape_absolute_values, priority=400)


# -- notebooks ---------------------------------------------------------------------------------
# The notebooks are stored without outputs; the build executes them (as tests/test_notebooks.py
# does) so that the guide shows current results and figures. Results are cached in
# _build/.jupyter_cache and a notebook runs again only when it changes; a failing cell fails
# the build.
nb_execution_mode = "cache"
nb_execution_cache_path = str(DOCS / "_build" / ".jupyter_cache")
nb_execution_timeout = 900
nb_execution_raise_on_error = True
nb_execution_show_tb = True
myst_enable_extensions = ["colon_fence", "dollarmath", "deflist"]
myst_heading_anchors = 3
# the kernel imports this checkout's tmaplan, whatever else the environment has installed
os.environ["PYTHONPATH"] = os.pathsep.join(
    [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])
os.environ.setdefault("MPLBACKEND", "Agg")

# The notebooks live in the top-level notebooks/ folder; copy them into the source tree at
# build time (a generated copy, ignored by git), so there is one committed copy of each.
_GUIDE = DOCS / "_generated" / "notebooks"
if _GUIDE.exists():
    shutil.rmtree(_GUIDE)
_GUIDE.mkdir(parents=True)
for _nb in sorted((ROOT / "notebooks").glob("*.ipynb")):
    shutil.copy2(_nb, _GUIDE / _nb.name)

# -- output ------------------------------------------------------------------------------------
html_theme = "furo"
html_title = f"tmaplan {release}"
html_static_path: list[str] = []
suppress_warnings = ["mystnb.unknown_mime_type"]
