"""A benchmark re-run replaces its generated table and keeps the notes (benchmarks/report.py)."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import pytest

from tests.module_files import load_module

REPORT = Path(__file__).resolve().parents[1] / "benchmarks" / "report.py"


@pytest.fixture(scope="module")
def report() -> ModuleType:
    return load_module("benchmark_report", REPORT)


NOTED = """<!-- begin hsva.py -->
# Cross-predictions
| old | table |
<!-- end hsva.py -->

Run of yesterday: what the table shows.

## Candidate terms

<!-- begin fidelity.py draws -->
| other | block |
<!-- end fidelity.py draws -->
hand-written tail
"""


def test_a_rerun_replaces_its_block_and_keeps_every_other_line(
    report: ModuleType, tmp_path: Path
) -> None:
    path = tmp_path / "hsva.md"
    path.write_text(NOTED, encoding="utf-8")
    report.write_block(path, "hsva.py", ["# Cross-predictions", "| new | table |", "| row | 2 |"])
    assert path.read_text(encoding="utf-8") == NOTED.replace(
        "| old | table |", "| new | table |\n| row | 2 |"
    )


def test_a_block_of_another_name_is_replaced_in_place(report: ModuleType, tmp_path: Path) -> None:
    path = tmp_path / "fidelity.md"
    path.write_text(NOTED, encoding="utf-8")
    report.write_block(path, "fidelity.py draws", ["| five | draws |"])
    assert path.read_text(encoding="utf-8") == NOTED.replace(
        "| other | block |", "| five | draws |"
    )


def test_a_report_without_the_block_gets_it_appended(report: ModuleType, tmp_path: Path) -> None:
    path = tmp_path / "notes.md"
    path.write_text("# Notes\nkept\n", encoding="utf-8")
    report.write_block(path, "sensitivity.py", ["| a |"])
    assert path.read_text(encoding="utf-8") == (
        "# Notes\nkept\n\n<!-- begin sensitivity.py -->\n| a |\n<!-- end sensitivity.py -->\n"
    )


def test_a_missing_report_is_created(report: ModuleType, tmp_path: Path) -> None:
    path = tmp_path / "new" / "environment.md"
    report.write_block(path, "environment.py", ["| row |"])
    assert path.read_text(encoding="utf-8") == (
        "<!-- begin environment.py -->\n| row |\n<!-- end environment.py -->\n"
    )


def test_a_block_without_its_end_is_an_error_and_the_report_stays(
    report: ModuleType, tmp_path: Path
) -> None:
    path = tmp_path / "hsva.md"
    broken = "notes\n<!-- begin hsva.py -->\n| old |\n"
    path.write_text(broken, encoding="utf-8")
    with pytest.raises(ValueError, match=r"hsva\.md: line 2: '<!-- begin hsva\.py -->' has no"):
        report.write_block(path, "hsva.py", ["| new |"])
    assert path.read_text(encoding="utf-8") == broken
