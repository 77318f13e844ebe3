"""The installed rangefx version, in a module light enough for ``rangefx --version``."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

__all__ = ["package_version"]


def package_version() -> str:
    """The installed rangefx version (``0+unknown`` from a source tree)."""
    try:
        return version("rangefx")
    except PackageNotFoundError:
        return "0+unknown"
