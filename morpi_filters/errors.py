"""The exception types for problems a user can cause.

A bad file, a bad parameter or a missing dataset raises one of the kinds of
:class:`MorpiError` below, with a message that names the file, line or
parameter and what was expected. Each kind is one cause, so a caller can
catch exactly the causes it can handle: :class:`ParameterError` catches every
bad argument, option or parameter (including a missing dataset, a refused
output and a failed download), :class:`DataError` every recording or dataset
that cannot be used as it is. The library never raises a plain
:class:`MorpiError`; catching it catches every kind. The command line prints
the message on one line and exits with the error's
:attr:`~MorpiError.exit_code`. Programming errors (bugs) are not wrapped and
keep their tracebacks.

Exit codes of ``morpi``: 0 success, 1 bad input data (:class:`DataError`),
2 bad arguments or parameters (:class:`ParameterError` and its kinds
:class:`MissingDataError`, :class:`OutputError` and :class:`FetchError`),
130 interrupted (SIGINT), 143 terminated (SIGTERM).
"""
from __future__ import annotations

__all__ = ["MorpiError", "DataError", "ParameterError", "MissingDataError", "OutputError", "FetchError"]


class MorpiError(Exception):
    """A user-facing error with a one-line, self-contained message (the base of every kind below)."""

    #: Exit status of ``morpi`` when this error ends a command.
    exit_code = 2


class DataError(MorpiError):
    """A recording or dataset that cannot be used as it is (exit status 1)."""

    exit_code = 1


class ParameterError(MorpiError):
    """An argument, option or parameter file outside what is accepted (exit status 2)."""

    exit_code = 2


class MissingDataError(ParameterError):
    """No dataset configured, or the configured dataset folder is not there (exit status 2)."""

    exit_code = 2


class OutputError(ParameterError):
    """An output folder or file that cannot or may not be written (exit status 2)."""

    exit_code = 2


class FetchError(ParameterError):
    """A dataset download that failed or gave an archive that does not match the checksums (exit status 2).

    ``morpi data fetch`` documents exit status 2 for every such failure,
    from the network to an unsafe member path; the archive is not a dataset
    in use yet, so this is not a :class:`DataError`.
    """

    exit_code = 2
