"""Write a benchmark's generated table into its markdown report, keeping the notes around it.

A report holds generated blocks, each between a ``<!-- begin NAME -->`` and an
``<!-- end NAME -->`` line (invisible in rendered markdown); everything else in it (the
notes on a run, tables of earlier runs kept for comparison) is written by hand.
:func:`write_block` replaces the block of one name and leaves the rest as it was, so a
re-run no longer wipes the notes (it did before: issue 13's sections of ``hsva.md``).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from fmu_model.atomic import write_atomic
from fmu_model.variants import family_name


def write_block(path: str | Path, name: str, lines: Sequence[str]) -> None:
    """Put ``lines`` between the ``name`` markers of the report at ``path``.

    The block replaces the one of that name, or is appended when the report has none; a
    missing report is created. Written atomically: a failed write leaves the old report.

    Raises
    ------
    ValueError
        The report has the begin marker of ``name`` but no end marker after it.

    """
    target = Path(path)
    begin, end = f"<!-- begin {name} -->", f"<!-- end {name} -->"
    block = [begin, *lines, end]
    old = target.read_text(encoding="utf-8").splitlines() if target.exists() else []
    if begin in old:
        first = old.index(begin)
        if end not in old[first + 1 :]:
            raise ValueError(f"{target}: line {first + 1}: '{begin}' has no '{end}' after it")
        last = old.index(end, first + 1)
        new = [*old[:first], *block, *old[last + 1 :]]
    else:
        new = [*old, *([""] if old and old[-1] else []), *block]
    write_atomic(target, "\n".join(new) + "\n")


def fitted_label(model: str, fitted: str) -> str:
    """Return ``model`` for a table's model column, with the family a fit refitted it as.

    ``identify`` refits a ``prime-rudder`` fit whose thrust is not a propeller's as
    ``prime-rudder-thrust`` (``fitted``, the params' structure name): "prime-rudder →
    prime-rudder-thrust". Otherwise ``model`` alone.
    """
    family = family_name(fitted)
    return model if family == family_name(model) else f"{model} → {family}"
