"""Many volumes at once: plan, convert, verify, journal and report.

``plan`` turns globs, folders and manifests into :class:`Task` objects (one input, one
output, the options for it); ``convert_one`` runs one task and returns a plain record;
``run`` runs many of them here (``concurrent.futures``) or on a Dask cluster
(``dask.distributed``) and returns a report. The same ``convert_one`` runs inline, in a
thread, in a worker process and on a Dask worker: it is a top-level function of a small
frozen dataclass, and it turns every error of its file into a ``failed`` record.

Local execution. With ``workers=1`` tasks run inline. With more, ``executor="auto"`` takes
a process pool when there are at least ``PROCESS_MIN_TASKS_PER_WORKER`` tasks per worker,
else a thread pool. The codec kernels release the GIL, so threads scale for lossless
coding (``scripts/bench_batch.py``: 12 real volumes, 2 cores, threads 3.8 s, processes
4.6 s, inline 6.8 s); but reading (nibabel, gzip), the lossy planner and the checks
around every brick are Python that holds the GIL, and separate processes keep one file's
crash (or the OOM killer) from taking the run with it (a broken pool is replaced and
the files in flight are reported failed). A worker process pays once for loading the
compiled kernels from the disk cache (about 0.7 s), which only a long batch amortises.
Each task may still code its bricks on threads (its ``workers`` option, ``--threads``
on the command line).

Memory. The driver estimates each input's voxel bytes from its header
(:func:`volpack.io.read_header`; a ``.vpk`` header for decoding) and counts a task as
three times that (the volume, its decoded copy for the check and the codec's working
set). It starts a task only while the tasks in flight fit in half the physical memory
(``os.sysconf``); a task larger than that runs alone. On Dask, the workers' own memory
limits apply instead.

Journal (``.volpack-batch.jsonl`` in the output folder). One JSON object per line,
appended and fsync'd by the driver after each task: ``output`` (relative to the
journal's folder), ``input``, ``input_size``, ``input_mtime_ns``, ``output_size``,
``output_sha256``, ``options_hash``, ``status``, the measured numbers and ``time``. The
last line for an output wins; a torn last line (a kill during the write) is ignored.
With ``resume``, a task is skipped only if that line says ``ok`` with the same options,
the input has the recorded size and mtime, and the output has the recorded size and
sha256; anything else is redone (outputs are written atomically, so a killed run leaves
no partial output under its final name, only ``.volpack-*.part`` files, which a resumed
run removes).
"""

from .convert import VerifyError, compare, convert_one, one_line
from .journal import Journal, input_stat, is_done, output_stat, sha256_file
from .planning import (
    COMPRESS_KEYS,
    JOURNAL_NAME,
    LOSSY_KEYS,
    OPTION_KEYS,
    READ_KEYS,
    BatchError,
    Task,
    normalize_options,
    plan,
    strip_volume_ext,
)
from .runner import estimate_nbytes, memory_budget, run, totals, write_report

__all__ = [
    "COMPRESS_KEYS",
    "JOURNAL_NAME",
    "LOSSY_KEYS",
    "OPTION_KEYS",
    "READ_KEYS",
    "BatchError",
    "Journal",
    "Task",
    "VerifyError",
    "compare",
    "convert_one",
    "estimate_nbytes",
    "input_stat",
    "is_done",
    "memory_budget",
    "normalize_options",
    "one_line",
    "output_stat",
    "plan",
    "run",
    "sha256_file",
    "strip_volume_ext",
    "totals",
    "write_report",
]
