"""Parallel maps over threads: in order with bounded look-ahead, or as completed.

Kernels release the GIL (numba ``nogil``), so threads give real parallelism without
copying bricks between processes. Results come back in input order, so the bytes a
caller writes do not depend on the number of workers.
"""

from __future__ import annotations

import collections
import contextlib
import os
import queue
import threading
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from typing import TypeVar

from .errors import OptionError

T = TypeVar("T")
R = TypeVar("R")


@contextlib.contextmanager
def one_blas_thread():
    """Run the body (or the decorated function) with BLAS on one thread.

    OpenBLAS splits a matrix product over its threads, and the split changes the order
    of the sums: a fit's normal equations, and so its float32 weights and the file, then
    depend on the machine's core count (the effort-max box fit of the CAM wind gave
    247,443 bytes on one BLAS thread and 247,440 on two). The encoders' entry points run
    under this guard, so their fits sum in one order on any machine with the same BLAS
    build; volpack's parallelism is its own workers. threadpoolctl lets only the thread
    that set a limit change it: the outermost guard (the caller's thread) holds it for
    the workers it starts, and guards met inside them change nothing."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


def default_workers() -> int:
    """Cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def memory_budget() -> int:
    """Half the physical memory, in bytes."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") // 2
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return 4 << 30


def auto_workers(tasks: int, task_bytes: int = 0) -> int:
    """Workers for ``tasks`` independent pieces of work needing about ``task_bytes`` of
    memory each: every core, but no more than there are tasks, and no more than half the
    memory holds at once."""
    n = min(default_workers(), max(1, tasks))
    if task_bytes > 0:
        n = min(n, max(1, memory_budget() // task_bytes))
    return n


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


def beside(fn: Callable[..., R], *args, name: str = "volpack-beside") -> Future:
    """A future of ``fn(*args)`` run on a thread of its own, started now; its
    ``result()`` (or ``exception()``) waits for it and hands back what it returned or
    raised. For one piece of work beside the caller's own (no pool to start or stop)."""
    future: Future = Future()

    def run() -> None:
        try:
            future.set_result(fn(*args))
        except BaseException as e:  # re-raised by result()
            future.set_exception(e)

    threading.Thread(target=run, name=name, daemon=True).start()
    return future


def completed_map(
    fn: Callable[[T], R], items: Iterable[T], workers: int = 1, ahead: int = 4
) -> Iterator[R]:
    """Yield ``fn(item)`` for each item as it completes, running up to ``workers`` at once.

    For work whose results do not depend on the order they arrive in (bricks decoded
    into their own part of one output): unlike :func:`ordered_map`, a slow item never
    holds back the next ones, so no worker waits while items are left. The caller's
    thread is one of the workers and ``workers - 1`` helpers join it; each takes the next
    item itself when it finishes one (under a lock), so no item passes through a pool's
    queue and no thread is woken to hand it over: with a pool (a submit, a worker woken,
    the caller woken by each result) two workers pinned to one CPU spent 5-12 % more CPU
    than one on bricks of about a millisecond, this way 3-5 %. Results of the helpers are
    yielded after the caller's next item, at most ``ahead * workers`` of them waiting; an
    error in any worker is raised here, and the helpers stop taking items when the
    generator ends.
    """
    if workers <= 1:
        yield from map(fn, items)
        return
    it = iter(items)
    lock = threading.Lock()
    stop = False
    results: queue.SimpleQueue = queue.SimpleQueue()  # (ok, value) of the helpers; _END each
    room = threading.Semaphore(ahead * workers)  # results not yet yielded

    def take():
        with lock:
            return _END if stop else next(it, _END)

    def helper() -> None:
        try:
            while room.acquire() and (item := take()) is not _END:
                results.put((True, fn(item)))
        except BaseException as e:  # noqa: BLE001 - handed to the caller, raised there
            results.put((False, e))
        results.put((True, _END))

    helpers = [threading.Thread(target=helper, daemon=True) for _ in range(workers - 1)]
    for t in helpers:
        t.start()
    running = len(helpers)

    def collect(block: bool) -> Iterator[R]:  # the helpers' results so far (block: all)
        nonlocal running
        while running and (block or not results.empty()):
            ok, r = results.get()
            if not ok:
                raise r
            if r is _END:
                running -= 1
            else:
                room.release()
                yield r

    try:
        while (item := take()) is not _END:
            yield fn(item)
            yield from collect(False)
        yield from collect(True)
    finally:
        with lock:
            stop = True
        room.release(len(helpers))  # each helper takes at most one more before it sees stop
        for t in helpers:
            t.join()


_END = object()  # no more items (or a helper's last word)


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
