"""Reading input files: special files, size bound, text decoding (trials.text_input)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from trials.errors import LogFormatError
from trials.logs import read_log
from trials.text_input import decode_utf8, read_bytes, split_fields


def test_regular_file_is_read(tmp_path: Path) -> None:
    path = tmp_path / "a.csv"
    path.write_bytes(b"x,y\n")
    assert read_bytes(str(path), "trial log") == b"x,y\n"


def test_a_file_over_the_bound_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "big.csv"
    path.write_bytes(b"0" * 101)
    assert read_bytes(str(path), "trial log", max_bytes=101) == b"0" * 101
    with pytest.raises(LogFormatError, match=r"big\.csv: larger than 100 bytes"):
        read_bytes(str(path), "trial log", max_bytes=100)


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="needs /dev/zero")
def test_dev_zero_is_refused_at_once() -> None:
    with pytest.raises(LogFormatError, match=r"/dev/zero: is a special file"):
        read_log("/dev/zero")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_a_fifo_without_writer_is_refused_not_waited_for(tmp_path: Path) -> None:
    fifo = tmp_path / "log.csv"
    os.mkfifo(fifo)
    # In a child process: a blocking open would hang the suite, here it times out.
    code = "import sys\nfrom trials.logs import read_log\nread_log(sys.argv[1])\n"
    done = subprocess.run(
        [sys.executable, "-c", code, str(fifo)], capture_output=True, text=True, timeout=60
    )
    assert done.returncode != 0 and "is a special file" in done.stderr


def test_directory_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(LogFormatError, match="is a directory; expected a recording file"):
        read_bytes(str(tmp_path), "recording")
    with pytest.raises(LogFormatError, match="no such file; expected an existing recording"):
        read_bytes(str(tmp_path / "nothing.nmea"), "recording")


@pytest.mark.parametrize(
    ("raw", "message", "line"),
    [
        (b"\xff\xfeh\x00", "UTF-16 byte-order mark", 1),
        (b"a\nb\x00", "NUL byte at offset 3", 2),
        (b"a\n\n\xe9", "invalid UTF-8 byte 0xe9 at offset 3", 3),
    ],
)
def test_not_text_is_named_with_its_line(raw: bytes, message: str, line: int) -> None:
    with pytest.raises(LogFormatError, match=message) as info:
        decode_utf8(raw, "f.csv", " (hint)")
    assert info.value.line == line
    assert message.startswith("UTF-16") or str(info.value).endswith("(hint)")


def test_split_fields_quoted_and_malformed() -> None:
    assert split_fields("1,2,3") == ["1", "2", "3"]
    assert split_fields('1,"a,b",3') == ["1", "a,b", "3"]
    assert split_fields('1,"a,3') is None
