"""``tmaplan problems``: list the built-in problems."""

from __future__ import annotations

import argparse
from typing import Any

from tmaplan.scenario import list_problems

HELP = "list the built-in problems"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """No options besides --json."""


def run(args: argparse.Namespace) -> list[dict[str, Any]]:
    """Print the problems (unless --json -) and return ``[{name, description}]``."""
    probs = list_problems()
    if args.json != "-":
        width = max(len(p["name"]) for p in probs)
        for p in probs:
            print(f"{p['name']:<{width}}  {p['description']}")
    return probs
