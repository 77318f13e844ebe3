"""The one exception type that means "the user made a mistake"."""

from __future__ import annotations

__all__ = ["UserError"]


class UserError(Exception):
    """A mistake in the user's input or invocation, not a bug in rangefx.

    The command line catches it, prints ``rangefx: error: <message>`` on one line and
    exits with status 2, without a traceback. The message must name the culprit (the
    file, option or value at fault).
    """
