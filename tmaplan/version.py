"""The package's version (``tmaplan --version``, the campaign records' ``tmaplan_version``).

At the bottom layer, so that the command line and the campaigns read it without importing the
package's front door (:mod:`tmaplan`, which re-exports it as ``tmaplan.__version__``).
"""

from __future__ import annotations

__all__ = ["__version__"]

__version__ = "0.3.0"
