"""Independent implementations kept only as cross-checks of the package."""
