"""write_atomic removes the temporary files its killed writers left behind, and nothing else.

A writer killed (``kill -9``) between creating its temporary file and the rename cannot
remove it; the next write to the same target removes such files once they are older
than ``STALE_TEMPORARY_AGE_S`` (tests/test_soak.py kills a real writer).
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from fmu_model.atomic import STALE_TEMPORARY_AGE_S, write_atomic


def _age(path: Path, seconds: float) -> None:
    """Set the modification time of ``path`` (not following a symlink) to ``seconds`` ago."""
    then = time.time() - seconds
    os.utime(path, (then, then), follow_symlinks=False)


def _make(path: Path, age_s: float, content: str = "left over") -> Path:
    path.write_text(content)
    _age(path, age_s)
    return path


OLD = STALE_TEMPORARY_AGE_S + 60.0  # a killed writer's file
YOUNG = STALE_TEMPORARY_AGE_S - 60.0  # perhaps a live writer's


def test_the_stale_temporaries_of_the_target_are_removed_on_the_next_write(
    tmp_path: Path,
) -> None:
    target = tmp_path / "params.json"
    stale = [
        _make(tmp_path / ".params.json.0123456789ab.tmp", OLD),
        _make(tmp_path / ".params.json.ffffffffffff.tmp", 24 * 3600.0, ""),  # empty, a day
    ]
    kept = [
        _make(tmp_path / ".params.json.ba9876543210.tmp", YOUNG),  # young
        _make(tmp_path / ".other.json.0123456789ab.tmp", OLD),  # another target's
        _make(tmp_path / ".params.json.0123456789AB.tmp", OLD),  # not our hex digits
        _make(tmp_path / ".params.json.0123456789a.tmp", OLD),  # 11 digits
        _make(tmp_path / ".params.json.0123456789abc.tmp", OLD),  # 13 digits
        _make(tmp_path / ".params.json.0123456789ab.tmp.bak", OLD),
        _make(tmp_path / "params.json.0123456789ab.tmp", OLD),  # not hidden
        _make(tmp_path / ".x.params.json.0123456789ab.tmp", OLD),  # a target named x.params.json...
    ]
    directory = tmp_path / ".params.json.aaaaaaaaaaaa.tmp"  # a directory is never removed
    directory.mkdir()
    _age(directory, OLD)
    elsewhere = _make(tmp_path / "precious.txt", OLD, "precious")
    link = tmp_path / ".params.json.bbbbbbbbbbbb.tmp"  # a symlink is never followed
    link.symlink_to(elsewhere)
    _age(link, OLD)

    write_atomic(target, "new\n")

    assert target.read_text() == "new\n"
    assert [p for p in stale if p.exists()] == []
    assert [p for p in kept if not p.exists()] == []
    assert directory.is_dir() and link.is_symlink() and elsewhere.read_text() == "precious"
    # Exactly what was there, less the stale files, plus the target: no new temporary.
    expected = {*kept, directory, elsewhere, link, target}
    assert set(tmp_path.iterdir()) == expected


@pytest.mark.parametrize(("age_s", "removed"), [(OLD, True), (YOUNG, False), (0.0, False)])
def test_only_temporaries_older_than_the_limit_are_removed(
    tmp_path: Path, age_s: float, removed: bool
) -> None:
    leftover = _make(tmp_path / ".report.md.00112233aabb.tmp", age_s)
    write_atomic(tmp_path / "report.md", b"# report\n")
    assert leftover.exists() is not removed


def test_a_target_name_with_regex_characters_matches_only_itself(tmp_path: Path) -> None:
    """The target's name is matched literally: '.' and '+' are not patterns."""
    target = tmp_path / "a+b.json"
    ours = _make(tmp_path / ".a+b.json.0123456789ab.tmp", OLD)
    similar = _make(tmp_path / ".aab.json.0123456789ab.tmp", OLD)  # 'a+b' as a regex
    similar_dot = _make(tmp_path / ".a+bXjson.0123456789ab.tmp", OLD)  # '.' as a regex
    write_atomic(target, "x")
    assert not ours.exists() and similar.exists() and similar_dot.exists()


def test_a_write_still_works_when_a_stale_temporary_cannot_be_removed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    leftover = _make(tmp_path / ".params.json.0123456789ab.tmp", OLD)
    real_unlink = os.unlink

    def refuse(path: str | os.PathLike[str], *args: object, **kwargs: object) -> None:
        if os.fspath(path) == str(leftover):
            raise PermissionError(13, "Permission denied", os.fspath(path))
        real_unlink(path)

    monkeypatch.setattr(os, "unlink", refuse)
    write_atomic(tmp_path / "params.json", "new")
    assert (tmp_path / "params.json").read_text() == "new" and leftover.exists()
