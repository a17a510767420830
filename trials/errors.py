"""The project's own exception types for bad input data.

Library code raises these; the command-line tools turn them into one line on stderr
and exit status 1 (DESIGN.md, "Command-line contract"). Each error carries where it
happened (file, line, column, sample) as attributes so that callers and tests can
inspect them without parsing the message, and ``str(err)`` is always a single line.
"""

from __future__ import annotations

import os

__all__ = ["IdentificationError", "LogFormatError", "one_line"]


def one_line(text: str) -> str:
    """Escape line breaks so that a message can never span several lines."""
    return text.replace("\r", "\\r").replace("\n", "\\n")


def _fspath_or_none(path: str | os.PathLike[str] | None) -> str | None:
    """Return ``os.fspath(path)``, or None when no path is given."""
    return None if path is None else os.fspath(path)


class LogFormatError(ValueError):
    """A trial log that cannot be read: malformed, incomplete or not a text file.

    ``str(err)`` is one line, ``"<path>:<line>: column '<col>': <message>"``, with the
    parts that are None left out, for example::

        trial.csv:17: column 'rudder_deg': expected a finite number, got 'abc'

    Parameters
    ----------
    message : str
        What is wrong, in the form ``"expected ..., got ..."`` where possible.
    path : str or os.PathLike or None
        The file the problem is in; None when the text did not come from a file.
    line : int or None
        1-based line number in the file; None when the problem concerns the whole
        file (missing file, too few rows, ...).
    column : str or None
        Name of the CSV column the bad value is in; None when not about one column.
    expected : str
        Short description of what the reader expected there, e.g.
        ``"a finite number"``; also part of ``message``.

    Attributes
    ----------
    message, path, line, column, expected
        The parameters above (``path`` converted to ``str``).

    """

    def __init__(
        self,
        message: str,
        path: str | os.PathLike[str] | None = None,
        line: int | None = None,
        column: str | None = None,
        expected: str = "",
    ) -> None:
        self.message = message
        self.path = _fspath_or_none(path)
        self.line = line
        self.column = column
        self.expected = expected
        # Every argument in ``args`` so that the error pickles (e.g. across pytest-xdist
        # or multiprocessing workers) and rebuilds with the same attributes.
        super().__init__(message, self.path, line, column, expected)

    def __str__(self) -> str:
        location = self.path or ""
        if self.line is not None:
            location = f"{location}:{self.line}" if location else f"line {self.line}"
        parts = [location] if location else []
        if self.column is not None:
            parts.append(f"column {self.column!r}")
        parts.append(self.message)
        return one_line(": ".join(parts))


class IdentificationError(RuntimeError):
    """Identification failed on otherwise well-formed data (e.g. the EKF diverged).

    ``str(err)`` is one line, ``"<log>: sample <sample>: <message>"``, with the parts
    that are None left out, for example::

        zigzag_10.csv: sample 412: covariance is not positive definite

    Parameters
    ----------
    message : str
        What went wrong.
    log : str or os.PathLike or None
        Path of the trial log being processed, if any.
    sample : int or None
        0-based index of the sample at which the failure was detected, if any.

    Attributes
    ----------
    message, log, sample
        The parameters above (``log`` converted to ``str``).

    """

    def __init__(
        self,
        message: str,
        log: str | os.PathLike[str] | None = None,
        sample: int | None = None,
    ) -> None:
        self.message = message
        self.log = _fspath_or_none(log)
        self.sample = sample
        super().__init__(message, self.log, sample)

    def __str__(self) -> str:
        parts = []
        if self.log is not None:
            parts.append(self.log)
        if self.sample is not None:
            parts.append(f"sample {self.sample}")
        parts.append(self.message)
        return one_line(": ".join(parts))
