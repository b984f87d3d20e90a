"""The exception types for problems a user can cause.

A bad file, a bad parameter or a missing dataset raises :class:`MorpiError`
(or one of its two kinds) with a message that names the file, line or
parameter and what was expected. The command line prints that message on one
line and exits with the error's :attr:`~MorpiError.exit_code`; library users
catch :class:`MorpiError` like any other exception. Programming errors (bugs)
are not wrapped and keep their tracebacks.

Exit codes of ``morpi``: 0 success, 1 bad input data (:class:`DataError`),
2 bad arguments or parameters (:class:`ParameterError`, and a plain
:class:`MorpiError`), 130 interrupted (SIGINT), 143 terminated (SIGTERM).
"""
from __future__ import annotations

__all__ = ["MorpiError", "DataError", "ParameterError"]


class MorpiError(Exception):
    """A user-facing error with a one-line, self-contained message."""

    #: Exit status of ``morpi`` when this error ends a command.
    exit_code = 2


class DataError(MorpiError):
    """A recording or dataset that cannot be used as it is (exit status 1)."""

    exit_code = 1


class ParameterError(MorpiError):
    """An argument, option or parameter file outside what is accepted (exit status 2)."""

    exit_code = 2
