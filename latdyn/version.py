"""The package version (one place; the checkpoint, the results and the CLI read it)."""
__version__ = "0.1.0"
