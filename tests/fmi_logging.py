"""FMI 2.0 callbacks that record an FMU's log messages, safe to create in any number.

fmpy formats the variadic logger arguments in a small C proxy (``fmpy.logging``) that
keeps the Python target in *one process-wide* pointer: every ``addLoggerProxy`` call
re-points it, also for fmpy's own default callbacks. Pointing it at a per-test ctypes
callback therefore leaves a dangling pointer once that test's callback is collected,
and a later FMU in the same process that logs through the defaults crashes (seen as
a segmentation fault in an unrelated test under pytest-xdist). So the proxy is pointed
once, at a trampoline that lives as long as the process; the trampoline dispatches on
``componentEnvironment`` to the recorder that instantiated the FMU, and prints like
fmpy's default logger for everybody else.
"""

from __future__ import annotations

import itertools
import weakref
from ctypes import byref, c_void_p
from typing import Any

from fmpy import calloc, free
from fmpy.fmi2 import (
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    printLogMessage,
)
from fmpy.logging import addLoggerProxy

_RECORDERS: weakref.WeakValueDictionary[int, LogRecorder] = weakref.WeakValueDictionary()
_KEYS = itertools.count(1)


def _dispatch(env: Any, name: bytes, status: int, category: bytes, message: bytes) -> None:
    recorder = _RECORDERS.get(env or 0)
    if recorder is None:
        printLogMessage(env, name, status, category, message)
    else:
        recorder.messages.append((status, category.decode(), message.decode()))


_TRAMPOLINE = fmi2CallbackLoggerTYPE(_dispatch)
_PROXIED = fmi2CallbackFunctions()
_PROXIED.logger = _TRAMPOLINE
addLoggerProxy(byref(_PROXIED))  # now _PROXIED.logger is the C proxy, its target ours


class LogRecorder:
    """fmi2 callbacks (``.callbacks``) recording (status, category, message) per call."""

    def __init__(self) -> None:
        self.messages: list[tuple[int, str, str]] = []
        self._key = next(_KEYS)
        _RECORDERS[self._key] = self
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = _PROXIED.logger
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self.callbacks.componentEnvironment = c_void_p(self._key)

    def last(self) -> tuple[int, str, str]:
        """The most recent message."""
        return self.messages[-1]
