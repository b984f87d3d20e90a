"""The one exception type for problems a user can cause.

A bad file, a bad parameter or a missing dataset raises :class:`MorpiError`
with a message that names the file, line or parameter and what was expected.
The command line prints that message on one line and exits with status 2;
library users catch it like any other exception. Programming errors (bugs)
are not wrapped and keep their tracebacks.
"""
from __future__ import annotations

__all__ = ["MorpiError"]


class MorpiError(Exception):
    """A user-facing error with a one-line, self-contained message."""
