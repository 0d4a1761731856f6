"""Running a batch here (inline, threads or processes, within a memory budget) or on a
Dask cluster, with the journal, and the report."""

import collections
import concurrent.futures as cf
import contextlib
import dataclasses
import glob
import json
import logging
import os
import tempfile
import time
from collections.abc import Callable, Iterable
from typing import Any

from ..errors import OptionError
from ..jsonsafe import jsonable
from ..metrics import throughput
from ..parallel import memory_budget, one_blas_thread
from .convert import convert_one, one_line
from .journal import Journal, input_stat, is_done
from .planning import READ_KEYS, BatchError, Task

log = logging.getLogger(__name__)


MEMORY_FACTOR = 3
PROCESS_MIN_TASKS_PER_WORKER = 8
STATUSES = ("ok", "failed", "skipped", "cancelled")

# The keys of every row of a report: a written row's, which a skipped row takes from the
# journal (a journal of an older version may lack some: None).
RECORD_KEYS = dict.fromkeys(("input", "output", "status", "error", *Journal.FIELDS))

Progress = Callable[[int, int, int], None]


# -- running ---------------------------------------------------------------------------


def estimate_nbytes(task: Task) -> int:
    """Memory one task needs: ``MEMORY_FACTOR`` times its voxel bytes (0 if unknown)."""
    import numpy as np

    from .. import io as vio

    try:
        if task.kind == "decompress":
            from ..format.container import Reader

            with Reader(task.input) as r:
                shape, dtype = r.header["shape"], r.header["dtype"]
        else:
            path = vio.parse_spec(task.input)[0]
            if os.path.isdir(path):  # slices: read_header would read them all
                return MEMORY_FACTOR * input_stat(task.input)["input_size"]
            read_kw = {k: task.options[k] for k in READ_KEYS if k in task.options}
            h = vio.read_header(task.input, **read_kw)
            shape, dtype = h["shape"], h["dtype"]
        return MEMORY_FACTOR * int(np.prod(shape, dtype=np.float64)) * np.dtype(dtype).itemsize
    except Exception:  # the task itself will report what is wrong
        return 0


@one_blas_thread()
def run(
    tasks: Iterable[Task],
    *,
    workers: int = 1,
    scheduler: Any = None,
    resume: bool = False,
    journal: str | None = None,
    fail_fast: bool = False,
    force: bool = False,
    progress: Progress | None = None,
    executor: str = "auto",
    memory_limit: int | None = None,
    dask_processes: bool = True,
    func: Callable[[Task], dict] = convert_one,
) -> dict[str, Any]:
    """Run ``tasks`` and return the report ``{"files": [records], "totals": {...}}``.

    Parameters
    ----------
    workers : int
        Tasks at once (0 = every core); on ``scheduler="local"`` the number of Dask
        workers (one thread each).
    scheduler : None, str or distributed.Client
        ``None`` runs here; ``"local"`` starts a ``LocalCluster`` (worker processes, or
        threads with ``dask_processes=False``); an address such as ``tcp://head:8786``
        connects to a running scheduler; a ``Client`` is used as it is. The inputs and
        outputs must be on a filesystem the workers and this process share.
    resume : bool
        Skip the tasks ``journal`` shows done and intact; redo the others.
    journal : str, optional
        The journal file (normally ``OUT_DIR/.volpack-batch.jsonl``).
    fail_fast : bool
        Stop starting tasks after the first failure (the ones running finish; the
        rest are reported ``cancelled``).
    force : bool
        Replace existing outputs. Without it (and without ``resume``) an existing
        output stops the run before anything runs.
    progress : callable(done, total, raw_bytes_done), optional
    executor : {"auto", "inline", "thread", "process"}
        Local execution (see the module notes).
    memory_limit : int, optional
        Bytes the tasks in flight may use locally (default half the physical memory).
    func : callable
        The task function (``convert_one``); tests swap it.
    """
    from ..parallel import parse_workers

    t0 = time.perf_counter()
    tasks = list(tasks)
    workers = parse_workers(workers)
    if resume and not journal:
        raise BatchError("expected a journal file to resume from, found none")
    _check_writable(tasks, journal)
    jr = Journal(journal) if journal else None
    previous = jr.load() if (jr and resume) else {}

    records: dict[int, dict] = {}
    todo: list[tuple[int, Task]] = []
    exists = []
    for i, t in enumerate(tasks):
        if resume and is_done(t, previous.get(jr.key(t.output)) if jr else None):
            j = previous[jr.key(t.output)]  # type: ignore[union-attr]
            records[i] = {
                **{k: j.get(k) for k in Journal.FIELDS},
                "input": t.input,
                "output": t.output,
                "status": "skipped",
                "seconds": 0.0,
            }
            continue
        present = os.path.exists(t.output)
        if present and not (resume or force or t.force):
            exists.append(t.output)
        todo.append((i, dataclasses.replace(t, force=t.force or force or present)))
    if exists:
        raise BatchError(
            f"{len(exists)} output(s) exist already (first: {exists[0]!r}); pass resume=True "
            "to continue a run or force=True to redo them"
        )
    if resume:
        _remove_stale_parts(t.output for _, t in todo)

    state = {"done": len(records), "bytes": 0, "stop": False}
    total = len(tasks)
    if progress is not None:
        progress(state["done"], total, 0)

    def on_result(i: int, rec: dict) -> None:
        records[i] = rec
        if jr is not None:
            jr.append(rec)
        state["done"] += 1
        if rec["status"] == "ok":
            state["bytes"] += rec.get("raw_nbytes") or 0
        elif fail_fast:
            state["stop"] = True
        if progress is not None:
            progress(state["done"], total, state["bytes"])

    try:
        if not todo:
            where = "nothing to do"
        elif scheduler is None:
            where = _run_local(todo, workers, executor, memory_limit, on_result, state, func)
        else:
            where = _run_dask(todo, scheduler, workers, dask_processes, on_result, state, func)
    finally:
        if jr is not None:
            jr.close()
    files = [
        {
            **RECORD_KEYS,  # every row the same keys, whatever its status (None: not known)
            **(records.get(i) or {"input": t.input, "output": t.output, "status": "cancelled"}),
        }
        for i, t in enumerate(tasks)
    ]
    return {
        "files": files,
        "totals": totals(files, time.perf_counter() - t0),
        "executor": where,
        "workers": workers,
    }


def totals(files: list[dict], seconds: float) -> dict[str, Any]:
    """Counts per status; bytes and ratio over the outputs now in place (ok and skipped);
    speeds over what this run converted."""
    count = collections.Counter(f["status"] for f in files)
    present = [f for f in files if f["status"] in ("ok", "skipped")]
    raw = sum(f.get("raw_nbytes") or 0 for f in present)
    packed = sum(f.get("nbytes") or 0 for f in present)
    done_raw = sum(f.get("raw_nbytes") or 0 for f in files if f["status"] == "ok")
    return {
        "files": len(files),
        **{s: count.get(s, 0) for s in STATUSES},
        "raw_nbytes": raw,
        "nbytes": packed,
        "ratio": raw / packed if packed else None,
        "seconds": seconds,
        "files_per_s": count.get("ok", 0) / max(seconds, 1e-9),
        "mb_per_s": throughput(done_raw, seconds),
    }


def _check_writable(tasks: list[Task], journal: str | None) -> None:
    """Create the output root and write a probe file in it, or raise a one-line error."""
    if not tasks:
        return
    dirs = [os.path.dirname(os.path.abspath(t.output)) for t in tasks]
    if journal:
        dirs.append(os.path.dirname(os.path.abspath(journal)))
    root = os.path.commonpath(dirs)
    try:
        os.makedirs(root, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".volpack-", suffix=".probe", dir=root)
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        raise BatchError(f"cannot write to the output folder {root!r}: {e.strerror or e}") from None


def _remove_stale_parts(outputs: Iterable[str]) -> None:
    for d in sorted({os.path.dirname(os.path.abspath(o)) for o in outputs}):
        for p in glob.glob(os.path.join(glob.escape(d), ".volpack-*.part")):
            with contextlib.suppress(OSError):
                os.unlink(p)
                log.info("removed %s, left by an interrupted run", p)


def _failed(task: Task, e: BaseException) -> dict[str, Any]:
    return {
        "input": task.input,
        "output": task.output,
        "status": "failed",
        "error": one_line(e),
        "options_hash": task.options_hash,
    }


def _run_local(todo, workers, executor, memory_limit, on_result, state, func) -> str:
    kind = executor
    if kind == "auto":
        many = len(todo) >= PROCESS_MIN_TASKS_PER_WORKER * workers
        kind = "inline" if workers <= 1 else "process" if many else "thread"
    if kind == "inline":
        for i, t in todo:
            if state["stop"]:
                break
            on_result(i, func(t))
        return "inline"
    if kind not in ("thread", "process"):
        raise OptionError(f"expected executor auto, inline, thread or process, found {kind!r}")
    budget = memory_limit if memory_limit is not None else memory_budget()
    need = {i: estimate_nbytes(t) for i, t in todo}
    queue = collections.deque(todo)
    pending: dict[cf.Future, tuple[int, Task]] = {}
    in_use = 0

    def make_pool():
        if kind == "thread":
            return cf.ThreadPoolExecutor(max_workers=workers)
        import multiprocessing

        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(["volpack.batch", "volpack.api"])
        return cf.ProcessPoolExecutor(max_workers=workers, mp_context=ctx)

    pool = make_pool()
    try:
        while pending or (queue and not state["stop"]):
            while queue and not state["stop"] and len(pending) < workers:
                i, t = queue[0]
                if pending and in_use + need[i] > budget:
                    break  # wait for memory
                if not pending and need[i] > budget:
                    log.warning(
                        "%s needs about %d MB, more than the budget", t.input, need[i] >> 20
                    )
                queue.popleft()
                pending[pool.submit(func, t)] = (i, t)
                in_use += need[i]
            done, _ = cf.wait(pending, return_when=cf.FIRST_COMPLETED)
            broken = False
            for f in done:
                i, t = pending.pop(f)
                in_use -= need[i]
                try:
                    rec = f.result()
                except cf.BrokenExecutor as e:
                    broken = True
                    rec = _failed(t, RuntimeError(f"the worker process died ({e})"))
                except Exception as e:
                    rec = _failed(t, e)
                on_result(i, rec)
            if broken:  # a process died (OOM killer?): the others in flight are lost too
                for i, t in list(pending.values()):
                    on_result(i, _failed(t, RuntimeError("the worker pool broke")))
                    in_use -= need[i]
                pending.clear()
                pool.shutdown(wait=False, cancel_futures=True)
                pool = make_pool()
    except BaseException:  # Ctrl-C: the files under way are dropped, not waited for
        _abandon(pool)
        raise
    pool.shutdown(wait=True, cancel_futures=True)
    return f"{kind} x{workers}"


def _abandon(pool: cf.Executor) -> None:
    """Shut ``pool`` down without waiting for the tasks under way: a thread's task runs
    on to its end unseen (its output is written atomically, so never named), a process
    is stopped. A batch interrupted with Ctrl-C waited minutes for its big files."""
    # (no public way to the processes; shutdown forgets them, so they are taken first)
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        with contextlib.suppress(Exception):
            proc.terminate()


def _run_dask(todo, scheduler, workers, processes, on_result, state, func) -> str:
    from distributed import as_completed

    from ..parallel import dask_client

    where = f"dask {scheduler if isinstance(scheduler, str) else 'client'}"
    with dask_client(scheduler, workers, processes) as client:
        index = {}
        futures = client.map(func, [t for _, t in todo], pure=False, retries=2)
        for f, (i, t) in zip(futures, todo):
            index[f.key] = (i, t)
        ac = as_completed(futures)
        for f in ac:
            i, t = index[f.key]
            try:
                rec = f.result()
            except Exception as e:
                rec = _failed(t, e)
            on_result(i, rec)
            if state["stop"]:
                left = [g for g in futures if not g.done()]
                client.cancel(left)
                break
    return where


def write_report(report: dict, path: str) -> None:
    """Write the report as strict JSON, atomically (an existing report is replaced)."""
    from ..format.atomic import atomic_open

    with atomic_open(path, force=True) as f:
        f.write(json.dumps(jsonable(report), indent=2, sort_keys=True, allow_nan=False).encode())
