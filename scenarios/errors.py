"""Error types of the scenarios; ``str()`` of each is one line, for the command line."""

from __future__ import annotations

__all__ = ["ScenarioError", "UncertaintyError"]


class ScenarioError(RuntimeError):
    """Bad input to a scenario (FMU, option, manoeuvre); ``str()`` is one line."""

    def __init__(self, message: str) -> None:
        super().__init__(message.replace("\r", "\\r").replace("\n", "\\n"))


class UncertaintyError(ValueError):
    """Input that a Monte-Carlo run cannot use; ``str()`` is one line."""
