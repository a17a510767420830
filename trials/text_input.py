"""Reading a text input file safely: the rules the trial-log reader and the converters share.

A file given on the command line may be missing, a directory, a special file (a FIFO
that never ends, ``/dev/zero``), far too large, or not UTF-8 text. Each case is a
one-line ``LogFormatError`` naming the file (and the line where there is one); nothing
is read without a bound.
"""

from __future__ import annotations

import csv
import os
import re
import stat
from typing import Final

from trials.errors import LogFormatError

MAX_INPUT_BYTES: Final = 256 << 20
"""Largest input file read [bytes]: 256 MiB, about 36 h of a 10 Hz NMEA recording
(position, heading, rudder, rpm), or 5 million trial-log rows; split longer ones."""

NUMBER: Final = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)
"""A decimal number as the formats accept it (no ``inf``, ``nan``, ``0x…`` or ``1_000``)."""

_MAX_SHOWN_CHARS: Final = 40


def show(text: str, limit: int = _MAX_SHOWN_CHARS) -> str:
    """Quote a file excerpt for an error message: repr, shortened if long."""
    if len(text) > limit:
        return repr(text[: limit - 3]) + "..."
    return repr(text)


def read_bytes(path: str, what: str, max_bytes: int = MAX_INPUT_BYTES) -> bytes:
    """Read a regular file of at most ``max_bytes``, or raise a one-line LogFormatError.

    Parameters
    ----------
    path : str
        The file.
    what : str
        What the file should be, for the messages (``"trial log"``, ``"recording"``).
    max_bytes : int
        Largest size accepted [bytes].

    """
    try:
        # Before opening: opening a FIFO without a writer blocks for ever.
        mode = os.stat(path).st_mode
        if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
            raise LogFormatError(
                f"is a special file (a device, FIFO or socket); expected a "
                f"{what.replace(' ', '-')} file",
                path=path,
                expected="a regular file",
            )
        with open(path, "rb") as file:
            raw = file.read(max_bytes + 1)
    except FileNotFoundError:
        raise LogFormatError(
            f"no such file; expected an existing {what}", path=path, expected="an existing file"
        ) from None
    except IsADirectoryError:
        raise LogFormatError(
            f"is a directory; expected a {what.replace(' ', '-')} file",
            path=path,
            expected="a file",
        ) from None
    except OSError as error:
        reason = error.strerror or type(error).__name__
        raise LogFormatError(
            f"cannot read the file ({reason})", path=path, expected="a readable file"
        ) from None
    if len(raw) > max_bytes:
        raise LogFormatError(
            f"larger than {max_bytes} bytes; expected a {what} of at most that size "
            "(split it into pieces)",
            path=path,
            expected=f"at most {max_bytes} bytes",
        )
    return raw


def decode_utf8(raw: bytes, path: str, hint: str = "") -> str:
    """Decode a file's bytes as UTF-8 (optional BOM), or explain why it is not text.

    ``hint`` is appended to the message when the file is not text (e.g. "convert it
    first").
    """
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise LogFormatError(
            "not a text file in UTF-8: it starts with a UTF-16 byte-order mark; "
            "expected UTF-8 text (save it as UTF-8)",
            path=path,
            line=1,
            expected="UTF-8 text",
        )
    nul = raw.find(b"\0")
    if nul >= 0:
        raise LogFormatError(
            f"not a text file: NUL byte at offset {nul}; expected UTF-8 text" + hint,
            path=path,
            line=raw.count(b"\n", 0, nul) + 1,
            expected="UTF-8 text",
        )
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise LogFormatError(
            f"not a text file: invalid UTF-8 byte 0x{raw[error.start]:02x} at offset "
            f"{error.start}; expected UTF-8 text" + hint,
            path=path,
            line=raw.count(b"\n", 0, error.start) + 1,
            expected="UTF-8 text",
        ) from None


def split_fields(line: str) -> list[str] | None:
    """Split one CSV line on ','; quoted fields (rare) go through the csv module.

    Returns None if the quoting is malformed.
    """
    if '"' not in line:
        return line.split(",")
    try:
        return next(csv.reader([line], strict=True))
    except csv.Error:
        return None
