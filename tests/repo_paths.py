"""Where a test finds the repository's files, whichever directory of ``tests/`` it sits in.

``tests/`` is on ``sys.path`` (pytest puts the directory of the root ``conftest.py`` there), so a
test in ``tests/<pkg>/`` imports this module as ``from repo_paths import DATA``.
"""

from __future__ import annotations

from pathlib import Path

#: ``tests/``
TESTS = Path(__file__).resolve().parent
#: ``tests/data/``: the invalid-input corpus, the recordings and the stored planning cases
DATA = TESTS / "data"
#: the repository's root (``docs/``, ``benchmarks/``, ``tmaplan/``)
ROOT = TESTS.parent
