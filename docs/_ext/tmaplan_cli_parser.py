"""The ``tmaplan`` argument parser, for sphinx-argparse (the CLI reference is generated)."""

from __future__ import annotations

import argparse


def parser() -> argparse.ArgumentParser:
    """The parser of the ``tmaplan`` command, with every verb's sub-parser."""
    from tmaplan.cli import _build_parser  # the CLI builds its parser in one place

    return _build_parser()[0]
