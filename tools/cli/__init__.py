"""The ``rangefx`` command line: :func:`main` dispatches to one module per subcommand."""

from .main import build_parser, main

__all__ = ["build_parser", "main"]
