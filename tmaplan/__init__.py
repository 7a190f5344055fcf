"""tmaplan — sensor management and observer-trajectory planning for target motion analysis."""

from __future__ import annotations

from tmaplan.version import __version__

__all__ = ["__version__"]
