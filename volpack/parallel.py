"""In-order parallel map over threads, with bounded look-ahead.

Kernels release the GIL (numba ``nogil``), so threads give real parallelism without
copying bricks between processes. Results come back in input order, so the bytes a
caller writes do not depend on the number of workers.
"""

from __future__ import annotations

import collections
import contextlib
import os
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from typing import TypeVar

from .errors import OptionError

T = TypeVar("T")
R = TypeVar("R")


def default_workers() -> int:
    """Cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def parse_workers(workers: int | None) -> int:
    """``None`` or 0 means every core; otherwise a positive count."""
    if workers is None or workers == 0:
        return default_workers()
    if workers < 0:
        raise OptionError(f"expected a worker count >= 0 (0 = all cores), found {workers}")
    return int(workers)


def ordered_map(
    fn: Callable[[T], R], items: Iterable[T], workers: int = 1, ahead: int = 4
) -> Iterator[R]:
    """Yield ``fn(item)`` for each item in order, running up to ``workers`` at once.

    At most ``ahead * workers`` results are pending, so memory stays bounded however
    many items there are.
    """
    if workers <= 1:
        yield from map(fn, items)
        return
    with ThreadPoolExecutor(max_workers=workers) as ex:
        pending: collections.deque = collections.deque()
        try:
            for item in items:
                pending.append(ex.submit(fn, item))
                if len(pending) >= ahead * workers:
                    yield pending.popleft().result()
            while pending:
                yield pending.popleft().result()
        finally:
            for f in pending:
                f.cancel()


def completed_map(
    fn: Callable[[T], R], items: Iterable[T], workers: int = 1, ahead: int = 4
) -> Iterator[R]:
    """Yield ``fn(item)`` for each item as it completes, running up to ``workers`` at once.

    For work whose results do not depend on the order they arrive in (bricks decoded
    into their own part of one output): unlike :func:`ordered_map`, a slow item never
    holds back the next ones, so no worker waits while items are left. At most ``ahead
    * workers`` are pending.
    """
    if workers <= 1:
        yield from map(fn, items)
        return
    with ThreadPoolExecutor(max_workers=workers) as ex:
        pending: set = set()
        try:
            for item in items:
                pending.add(ex.submit(fn, item))
                if len(pending) >= ahead * workers:
                    done, pending = wait(pending, return_when=FIRST_COMPLETED)
                    for f in done:
                        yield f.result()
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for f in done:
                    yield f.result()
        finally:
            for f in pending:
                f.cancel()


@contextlib.contextmanager
def dask_client(scheduler, workers: int, processes: bool = True):
    """A ``distributed.Client`` for ``scheduler``: ``"local"`` starts a ``LocalCluster``
    of ``workers`` single-threaded workers (processes or threads), a string is a
    scheduler address, anything else is a client used as it is. What is started here
    is closed on exit."""
    from distributed import Client, LocalCluster

    if not isinstance(scheduler, str):
        yield scheduler
        return
    with contextlib.ExitStack() as stack:
        if scheduler == "local":
            cluster = stack.enter_context(
                LocalCluster(
                    n_workers=workers,
                    threads_per_worker=1,
                    processes=processes,
                    dashboard_address=":0",
                )
            )
            yield stack.enter_context(Client(cluster))
        else:
            yield stack.enter_context(Client(scheduler))
