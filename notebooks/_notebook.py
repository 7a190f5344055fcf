"""Write a notebook of the ``notebooks/_make_*.py`` scripts: the one place that builds the
notebook object (cells, no outputs, the Python 3 kernel) and writes it next to the scripts."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

KERNELSPEC = {"name": "python3", "display_name": "Python 3", "language": "python"}


def build(cells: Iterable[Any]) -> nbformat.NotebookNode:
    """The notebook of ``cells``: ``("md" | "code", source)`` pairs or nbformat cells."""
    nb = new_notebook()
    nb.cells = [c if not isinstance(c, tuple) else
                new_markdown_cell(c[1]) if c[0] == "md" else new_code_cell(c[1])
                for c in cells]
    nb.metadata["kernelspec"] = dict(KERNELSPEC)
    return nb


def write(name: str, cells: Iterable[Any]) -> Path:
    """Write ``notebooks/<name>.ipynb`` and say so."""
    path = Path(__file__).resolve().with_name(f"{name}.ipynb")
    nbformat.write(build(cells), path)
    print(f"wrote {path}")
    return path
