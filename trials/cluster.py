"""``dask.distributed`` clients: a quiet local cluster of single-threaded workers, or a scheduler.

The batch identification (``identifier.batch``) and the Monte Carlo
(``scenarios.uncertainty``) both run their tasks on a ``LocalCluster`` made for the call:
``n_workers`` processes (or threads) of one thread each, no dashboard, and nothing logged
(``silence_logs`` at CRITICAL for the cluster and its workers). Its teardown (the client
closed first, then the cluster) runs with distributed's loggers silenced
(:class:`QuietTeardown`): the shutdown races the workers' heartbeats and open comms, and
what distributed logs about that (errors with tracebacks) is noise to a caller that
already has its results. A running scheduler given by its address
(``--scheduler tcp://host:8786``) is reached by :func:`scheduler_client`, which gives up
after :data:`SCHEDULER_TIMEOUT_S`.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from distributed import Client

SCHEDULER_TIMEOUT_S = 10.0
"""How long a client waits for a scheduler given by its address to answer [s]."""

TEARDOWN_LOGGERS = ("distributed", "tornado", "asyncio", "bokeh")
"""Loggers that report a local cluster's teardown: lost comms, failed heartbeats, late
tasks (distributed's own, and those of the event loops under it)."""


class QuietTeardown:
    """Silence :data:`TEARDOWN_LOGGERS` from :meth:`start` until the context exits.

    Every logger of those trees with a level of its own is raised above CRITICAL and put
    back on exit.
    """

    def __init__(self) -> None:
        self._saved: dict[logging.Logger, int] = {}

    def start(self) -> None:
        """Silence the loggers (idempotent)."""
        if self._saved:
            return
        names = [
            name
            for name in logging.root.manager.loggerDict
            if name.split(".")[0] in TEARDOWN_LOGGERS
        ]
        for name in {*TEARDOWN_LOGGERS, *names}:
            logger = logging.getLogger(name)
            if name in TEARDOWN_LOGGERS or logger.level != logging.NOTSET:
                self._saved[logger] = logger.level
                logger.setLevel(logging.CRITICAL + 1)

    def __enter__(self) -> QuietTeardown:
        return self

    def __exit__(self, *exc_info: object) -> None:
        for logger, level in self._saved.items():
            logger.setLevel(level)
        self._saved.clear()


@contextmanager
def local_client(n_workers: int, *, processes: bool = True) -> Iterator[Client]:
    """Yield a client of a new, silent ``LocalCluster`` of ``n_workers`` one-thread workers.

    Parameters
    ----------
    n_workers : int
        Worker processes (threads with ``processes=False``).
    processes : bool
        Workers in processes of their own (the default) or threads of this one.

    Yields
    ------
    distributed.Client
        Closed before its cluster, both with distributed's loggers silenced.

    """
    from distributed import Client, LocalCluster

    with (
        QuietTeardown() as quiet,
        LocalCluster(
            n_workers=n_workers,
            threads_per_worker=1,
            processes=processes,
            dashboard_address=None,  # no dashboard (the scheduler's on any free port)
            scheduler_kwargs={"dashboard_address": ":0"},
            silence_logs=logging.CRITICAL,
        ) as cluster,
        Client(cluster) as client,  # closed before the cluster
    ):
        try:
            yield client
        finally:
            quiet.start()  # until the cluster is closed


@contextmanager
def scheduler_client(address: str) -> Iterator[Client]:
    """Yield a client of the running dask scheduler at ``address`` (``tcp://host:port``).

    Raises
    ------
    OSError
        Naming the address when the scheduler does not answer within
        :data:`SCHEDULER_TIMEOUT_S`.

    """
    from distributed import Client

    with Client(address, timeout=SCHEDULER_TIMEOUT_S) as client:
        yield client


@contextmanager
def cluster_client(
    scheduler: str | None, n_workers: int, *, processes: bool = True
) -> Iterator[Client]:
    """Yield a client of ``scheduler`` or, when None, of a new local cluster.

    The scheduler's is :func:`scheduler_client`'s (an OSError when it does not answer), the
    local cluster :func:`local_client`'s (``n_workers``, ``processes``; silent).
    """
    if scheduler is not None:
        with scheduler_client(scheduler) as client:
            yield client
    else:
        with local_client(n_workers, processes=processes) as client:
            yield client
