"""Exceptions of the FMU exporters.

``str(err)`` is always one line; ``build_fmu.py`` prints it on stderr and exits with 1.
"""

from __future__ import annotations

__all__ = ["FmuBuildError"]


class FmuBuildError(RuntimeError):
    """An FMU could not be built (unknown model, no compiler, compile failure, ...).

    Parameters
    ----------
    message : str
        What went wrong; line breaks are escaped so that the message is one line.

    """

    def __init__(self, message: str) -> None:
        self.message = message.replace("\r", "\\r").replace("\n", "\\n")
        super().__init__(self.message)
