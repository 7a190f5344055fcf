"""tmaplan — sensor management and observer-trajectory planning for target motion analysis."""

from __future__ import annotations

__version__ = "0.3.0"
