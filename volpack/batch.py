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

from __future__ import annotations

import collections
import concurrent.futures as cf
import contextlib
import csv
import dataclasses
import glob
import hashlib
import json
import logging
import os
import tempfile
import time
from collections.abc import Callable, Iterable, Sequence
from typing import Any

from .errors import OptionError, VolpackError
from .jsonsafe import finite_json

log = logging.getLogger(__name__)

JOURNAL_NAME = ".volpack-batch.jsonl"
COMPRESS_KEYS = (
    "codec",
    "wavelet",
    "coder",
    "order",
    "max_levels",
    "brick",
    "max_error",
    "rel_error",
    "psnr",
    "ratio",
    "quality",
    "threshold",
    "fill_value",
    "workers",
)
LOSSY_KEYS = ("max_error", "rel_error", "psnr", "ratio", "quality", "threshold")
READ_KEYS = ("shape", "dtype", "byteorder", "offset")
OPTION_KEYS = COMPRESS_KEYS + READ_KEYS
_FLOAT_KEYS = {"max_error", "rel_error", "psnr", "ratio", "threshold", "fill_value"}
_INT_KEYS = {"max_levels", "quality", "workers", "offset"}
_UNHASHED = {"workers"}  # the output does not depend on them
MANIFEST_EXTS = (".csv", ".json")
MEMORY_FACTOR = 3
PROCESS_MIN_TASKS_PER_WORKER = 8
STATUSES = ("ok", "failed", "skipped", "cancelled")

Progress = Callable[[int, int, int], None]


class BatchError(VolpackError, ValueError):
    """A batch cannot start: nothing matches, two inputs share an output, no access..."""


class VerifyError(VolpackError):
    """An output does not decode to its input (within the bound)."""


@dataclasses.dataclass(frozen=True)
class Task:
    """One conversion: ``input`` (a volume spec, or a ``.vpk`` for ``kind="decompress"``),
    ``output`` (a path), ``options`` (compress and raw-read options), how to check it."""

    input: str
    output: str
    options: dict = dataclasses.field(default_factory=dict)
    kind: str = "compress"
    verify: str = "decode"
    force: bool = False

    @property
    def options_hash(self) -> str:
        opts = {k: v for k, v in self.options.items() if k not in _UNHASHED}
        blob = json.dumps({"kind": self.kind, "options": opts}, sort_keys=True, default=str)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]


# -- planning --------------------------------------------------------------------------


def plan(
    inputs: str | Sequence[str],
    out_dir: str,
    *,
    suffix: str = ".vpk",
    options: dict | None = None,
    kind: str = "compress",
    verify: str = "decode",
) -> list[Task]:
    """Expand ``inputs`` into tasks writing under ``out_dir``.

    Each input is a glob (``**`` recurses; ``'run/*.h5:/T'`` keeps the dataset), a
    folder (every readable volume under it; hidden files, raw files without a
    ``shape`` option and, for compression, ``.vpk`` files are left out; folders of
    slices are not volumes here: name them, or list them in a manifest), a file, or a
    ``.csv``/``.json`` manifest (column ``input``, optional ``output`` relative to
    ``out_dir``, optional per-file options overriding ``options``; inputs relative to
    the manifest's folder). Outputs mirror the inputs' tree below their common root,
    the volume extension replaced by ``suffix``. An input named twice is planned once;
    two inputs mapping to one output raise :class:`BatchError`.
    """
    from . import io as vio

    if kind not in ("compress", "decompress"):
        raise OptionError(f"expected kind 'compress' or 'decompress', found {kind!r}")
    if verify not in ("decode", "checksum"):
        raise OptionError(f"expected verify 'decode' or 'checksum', found {verify!r}")
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [os.fspath(inputs)]
    base_opts = normalize_options(options or {})
    out_abs = os.path.abspath(out_dir)
    # (spec, root folder, per-file options, explicit output)
    entries: list[tuple[str, str, dict, str | None]] = []
    for inp in inputs:
        inp = os.fspath(inp)
        path, inner = vio.parse_spec(inp)
        tail = f":{inner}" if inner else ""
        if path.lower().endswith(MANIFEST_EXTS) and os.path.isfile(path):
            entries += _read_manifest(path)
        elif glob.has_magic(path):
            found = [
                m + tail
                for m in sorted(glob.glob(path, recursive=True))
                if _selectable(m, kind, base_opts, out_abs, tree=False)
            ]
            if not found:
                raise BatchError(f"expected volumes matching {inp!r}, found none")
            entries += [(m, _glob_root(path), {}, None) for m in found]
        elif os.path.isdir(path):
            found = _walk(path, kind, base_opts, out_abs)
            if not found:
                raise BatchError(f"expected readable volumes under the folder {path!r}, found none")
            entries += [(m, path, {}, None) for m in found]
        elif os.path.exists(path):
            entries.append((inp, os.path.dirname(path) or ".", {}, None))
        else:
            raise BatchError(f"expected a file, folder, glob or manifest, found nothing at {inp!r}")
    if not entries:
        raise BatchError("expected at least one input, found none")

    root = os.path.commonpath([os.path.abspath(r) for _, r, _, _ in entries])
    tasks: list[Task] = []
    seen_inputs: set[tuple[str, str | None]] = set()
    owner: dict[str, str] = {}
    for spec, _, per_file, explicit in entries:
        path, inner = vio.parse_spec(spec)
        key = (os.path.realpath(path), inner)
        if key in seen_inputs:
            continue
        seen_inputs.add(key)
        if explicit:
            out = explicit if os.path.isabs(explicit) else os.path.join(out_dir, explicit)
        else:
            rel = os.path.relpath(os.path.abspath(path), root)
            out = os.path.join(out_dir, strip_volume_ext(rel) + suffix)
        out = os.path.normpath(out)
        other = owner.get(os.path.abspath(out))
        if other is not None:
            raise BatchError(f"inputs {other!r} and {spec!r} would both be written to {out!r}")
        owner[os.path.abspath(out)] = spec
        opts = dict(base_opts)
        if any(k in per_file for k in LOSSY_KEYS):
            opts = {k: v for k, v in opts.items() if k not in LOSSY_KEYS}
        opts.update(per_file)
        tasks.append(Task(spec, out, opts, kind, verify))
    inputs_abs = {os.path.realpath(vio.parse_spec(t.input)[0]) for t in tasks}
    for t in tasks:
        if os.path.realpath(t.output) in inputs_abs:
            raise BatchError(f"output {t.output!r} would overwrite an input; choose another folder")
    return tasks


def normalize_options(options: dict) -> dict:
    """Drop unset options and convert strings (a CSV cell) to the types the API takes."""
    out: dict[str, Any] = {}
    for k, v in options.items():
        if k not in OPTION_KEYS:
            raise BatchError(f"expected options among {', '.join(OPTION_KEYS)}, found {k!r}")
        if v is None or (isinstance(v, str) and not v.strip()):
            continue
        try:
            if k in _FLOAT_KEYS:
                v = float(v)
            elif k in _INT_KEYS:
                v = int(v)
            elif k in ("brick", "shape") and isinstance(v, str):
                nums = tuple(int(p) for p in v.replace("x", ",").split(","))
                v = nums[0] if len(nums) == 1 and k == "brick" else nums
            elif isinstance(v, list):
                v = tuple(v)
        except ValueError:
            raise BatchError(f"expected a number for option {k!r}, found {v!r}") from None
        out[k] = v
    return out


def strip_volume_ext(path: str) -> str:
    """``a/b.nii.gz`` -> ``a/b`` (the longest known volume extension, if any)."""
    from .io import _EXTENSIONS

    low = path.lower()
    for ext in sorted(_EXTENSIONS, key=len, reverse=True):
        if low.endswith(ext):
            return path[: -len(ext)]
    return path


def _glob_root(pattern: str) -> str:
    parts = []
    for part in pattern.split(os.sep):
        if glob.has_magic(part):
            break
        parts.append(part)
    root = os.sep.join(parts)
    if root == pattern:  # pragma: no cover - has_magic said otherwise
        root = os.path.dirname(pattern)
    return root or ("/" if pattern.startswith(os.sep) else ".")


def _selectable(path: str, kind: str, opts: dict, out_abs: str, tree: bool) -> bool:
    """Whether a path found by a glob (``tree=False``) or a walk is an input to take."""
    from . import io as vio

    if os.path.basename(path).startswith("."):
        return False
    try:
        fmt = vio.detect_format(path)
    except (VolpackError, OSError):
        return False
    if kind == "decompress":
        return fmt == "vpk" and os.path.isfile(path)
    if os.path.isdir(path):
        return not tree
    if tree and fmt == "vpk":
        return False
    if fmt == "raw" and "shape" not in opts:
        return False
    if path.lower().endswith(".img") and os.path.exists(path[:-4] + ".hdr"):
        return False  # the Analyze pair is read through its .hdr
    return not os.path.abspath(path).startswith(out_abs + os.sep)


def _walk(folder: str, kind: str, opts: dict, out_abs: str) -> list[str]:
    found = []
    for here, dirs, files in os.walk(folder):
        dirs[:] = sorted(
            d
            for d in dirs
            if not d.startswith(".") and os.path.abspath(os.path.join(here, d)) != out_abs
        )
        for name in sorted(files):
            p = os.path.join(here, name)
            if _selectable(p, kind, opts, out_abs, tree=True):
                found.append(p)
    return found


def _read_manifest(path: str) -> list[tuple[str, str, dict, str | None]]:
    base = os.path.dirname(path)
    try:
        if path.lower().endswith(".json"):
            with open(path, encoding="utf-8") as f:
                rows = json.load(f)
            if isinstance(rows, dict):
                rows = rows.get("files")
            if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
                raise BatchError(
                    f"expected a JSON list of objects (or {{'files': [...]}}) in {path!r}"
                )
        else:
            with open(path, newline="", encoding="utf-8") as f:
                rows = list(csv.DictReader(f))
    except (json.JSONDecodeError, csv.Error, UnicodeDecodeError) as e:
        raise BatchError(f"cannot read the manifest {path!r}: {e}") from None
    out = []
    for n, row in enumerate(rows, 1):
        row = {str(k).strip(): v for k, v in row.items() if k is not None}
        spec = str(row.pop("input", "") or "").strip()
        if not spec:
            raise BatchError(f"expected an 'input' in every row of {path!r}, row {n} has none")
        explicit = str(row.pop("output", "") or "").strip() or None
        try:
            per_file = normalize_options(row)
        except BatchError as e:
            raise BatchError(f"{path!r} row {n}: {e}") from None
        if not os.path.isabs(spec):
            spec = os.path.join(base, spec)
        from .io import parse_spec

        if not os.path.exists(parse_spec(spec)[0]):
            raise BatchError(f"{path!r} row {n}: expected an input, found nothing at {spec!r}")
        out.append((spec, os.path.dirname(parse_spec(spec)[0]) or ".", per_file, explicit))
    return out


# -- one task --------------------------------------------------------------------------


def convert_one(task: Task) -> dict[str, Any]:
    """Run one task and return its record; never raises for a problem of its file.

    ``status`` is ``ok`` (written and verified) or ``failed`` (``error`` says why; a
    written output that fails verification is removed). Also ``raw_nbytes`` (voxel
    bytes), ``nbytes`` (the ``.vpk`` file's size), ``ratio``, ``max_error`` and ``psnr``
    (measured; ``None`` when lossless), ``seconds``, and the input's size and mtime and
    the output's size and sha256 for the journal.
    """
    t0 = time.perf_counter()
    rec: dict[str, Any] = {
        "input": task.input,
        "output": task.output,
        "status": "failed",
        "error": None,
        "raw_nbytes": None,
        "nbytes": None,
        "ratio": None,
        "max_error": None,
        "psnr": None,
        "options_hash": task.options_hash,
    }
    try:
        rec.update(input_stat(task.input))
        if task.kind == "compress":
            rec.update(_compress_one(task))
        elif task.kind == "decompress":
            rec.update(_decompress_one(task))
        else:
            raise OptionError(f"expected kind 'compress' or 'decompress', found {task.kind!r}")
        rec.update(output_stat(task.output))
        rec["status"] = "ok"
    except Exception as e:  # one file's problem is its record, not the run's
        rec["error"] = one_line(e)
    rec["seconds"] = time.perf_counter() - t0
    return rec


def _compress_one(task: Task) -> dict[str, Any]:
    from . import api
    from . import io as vio

    read_kw = {k: task.options[k] for k in READ_KEYS if k in task.options}
    comp_kw = {k: task.options[k] for k in COMPRESS_KEYS if k in task.options}
    vol = vio.read_volume(task.input, **read_kw)
    os.makedirs(os.path.dirname(os.path.abspath(task.output)), exist_ok=True)
    stats = api.compress(vol, task.output, force=task.force, **comp_kw)
    try:
        if task.verify == "decode":
            back = api.decompress(task.output, workers=comp_kw.get("workers", 1))
            err, psnr = compare(vol.data, back.data, stats)
        else:
            _check_chunks(task.output)
            err = None if stats["lossless"] else stats["max_error"]
            psnr = stats.get("psnr")
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(task.output)
        raise
    size = os.path.getsize(task.output)
    return {
        "raw_nbytes": stats["raw_nbytes"],
        "nbytes": size,
        "ratio": stats["raw_nbytes"] / max(size, 1),
        "lossless": stats["lossless"],
        "max_error": err,
        "psnr": psnr,
    }


def _decompress_one(task: Task) -> dict[str, Any]:
    import numpy as np

    from . import api
    from . import io as vio

    vol = api.decompress(task.input, workers=task.options.get("workers", 1))  # CRCs checked
    os.makedirs(os.path.dirname(os.path.abspath(task.output)), exist_ok=True)
    vio.write_volume(vol, task.output, force=task.force)
    if task.verify == "decode":
        back = vio.read_volume(task.output)
        if back.shape != vol.shape or not np.array_equal(
            back.data, vol.data, equal_nan=vol.dtype.kind == "f"
        ):
            with contextlib.suppress(OSError):
                os.unlink(task.output)
            raise VerifyError(f"{task.output}: reading it back does not give the decoded volume")
    size = os.path.getsize(task.input)
    return {"raw_nbytes": vol.nbytes, "nbytes": size, "ratio": vol.nbytes / max(size, 1)}


def _check_chunks(path: str) -> None:
    from .format.container import Reader

    with Reader(path, verify=True) as r:
        for _ in r:  # every payload read, every CRC checked
            pass


def compare(a, b, stats: dict, block: int = 1 << 22) -> tuple[float | None, float | None]:
    """Check the decoded ``b`` against the input ``a``: equal when lossless, within the
    stored bound when there is one; special values (NaN, Inf) must come back exactly.
    Return the measured ``(max_error, psnr)`` (``None, None`` when lossless). Works in
    blocks so the float64 differences never cost more than a few tens of MB."""
    import numpy as np

    if a.shape != b.shape:
        raise VerifyError(f"expected the decoded shape {a.shape}, found {b.shape}")
    fa, fb = a.reshape(-1), b.reshape(-1)
    if stats.get("lossless", False):
        for i in range(0, fa.size, block):
            x, y = fa[i : i + block], fb[i : i + block]
            if not np.array_equal(x, y, equal_nan=x.dtype.kind == "f"):
                raise VerifyError("expected a lossless round trip, found different voxels")
        return None, None
    worst, sse, n, lo, hi = 0.0, 0.0, 0, np.inf, -np.inf
    for i in range(0, fa.size, block):
        x = fa[i : i + block].astype(np.float64)
        y = fb[i : i + block].astype(np.float64)
        fin = np.isfinite(x)
        special = ~fin
        if special.any() and not np.array_equal(x[special], y[special], equal_nan=True):
            raise VerifyError("expected NaN/Inf voxels restored exactly, found them changed")
        d = np.abs(x[fin] - y[fin])
        if d.size:
            worst = max(worst, float(d.max()))
            sse += float(np.dot(d, d))
            n += d.size
            lo, hi = min(lo, float(x[fin].min())), max(hi, float(x[fin].max()))
    bound = stats.get("error_bound")
    if bound is not None and worst > bound * (1 + 1e-12):
        raise VerifyError(f"expected every voxel within {bound:g}, found an error of {worst:g}")
    mse = sse / n if n else 0.0
    peak = (hi - lo) if n and hi > lo else 1.0
    psnr = None if mse == 0 else float(10 * np.log10(peak * peak / mse))
    return worst, psnr


def input_stat(spec: str) -> dict[str, int]:
    """Size and mtime of an input (a folder: the sum and latest of its files)."""
    from .io import parse_spec

    path = parse_spec(spec)[0]
    st = os.stat(path)
    if os.path.isdir(path):
        size, mtime = 0, st.st_mtime_ns
        with os.scandir(path) as it:
            for e in it:
                if e.is_file():
                    s = e.stat()
                    size, mtime = size + s.st_size, max(mtime, s.st_mtime_ns)
        return {"input_size": size, "input_mtime_ns": mtime}
    return {"input_size": st.st_size, "input_mtime_ns": st.st_mtime_ns}


def output_stat(path: str) -> dict[str, Any]:
    return {"output_size": os.path.getsize(path), "output_sha256": sha256_file(path)}


def sha256_file(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            h.update(chunk)
    return h.hexdigest()


def one_line(e: BaseException) -> str:
    msg = str(e) or type(e).__name__
    if isinstance(e, OSError) and e.filename and e.strerror:
        msg = f"{e.filename}: {e.strerror}"
    if not isinstance(e, VolpackError):
        msg = f"{type(e).__name__}: {msg}"
    return " ".join(msg.split())


# -- the journal -----------------------------------------------------------------------


class Journal:
    """The resume journal: JSON lines, appended and fsync'd one record at a time."""

    FIELDS = (
        "input",
        "input_size",
        "input_mtime_ns",
        "output_size",
        "output_sha256",
        "options_hash",
        "status",
        "error",
        "raw_nbytes",
        "nbytes",
        "ratio",
        "max_error",
        "psnr",
        "seconds",
    )

    def __init__(self, path: str) -> None:
        self.path = os.fspath(path)
        self.base = os.path.dirname(os.path.abspath(self.path))
        self._f = None

    def key(self, output: str) -> str:
        return os.path.relpath(os.path.abspath(output), self.base)

    def load(self) -> dict[str, dict]:
        """The last record of each output; unreadable lines (a torn write) are skipped."""
        last: dict[str, dict] = {}
        try:
            with open(self.path, encoding="utf-8") as f:
                for line in f:
                    try:
                        rec = json.loads(line)
                    except json.JSONDecodeError:
                        continue
                    if isinstance(rec, dict) and isinstance(rec.get("output"), str):
                        last[rec["output"]] = rec
        except FileNotFoundError:
            pass
        return last

    def append(self, rec: dict) -> None:
        if self._f is None:
            os.makedirs(self.base, exist_ok=True)
            self._f = open(self.path, "a", encoding="utf-8")  # noqa: SIM115 - closed in close()
        line = {"output": self.key(rec["output"]), "time": time.time()}
        line.update({k: rec.get(k) for k in self.FIELDS})
        self._f.write(json.dumps(finite_json(line), sort_keys=True) + "\n")
        self._f.flush()
        os.fsync(self._f.fileno())

    def close(self) -> None:
        if self._f is not None:
            self._f.close()
            self._f = None


def is_done(task: Task, rec: dict | None) -> bool:
    """Whether the journal record shows ``task`` done, with its output intact."""
    if not rec or rec.get("status") != "ok" or rec.get("options_hash") != task.options_hash:
        return False
    try:
        now = input_stat(task.input)
        if (now["input_size"], now["input_mtime_ns"]) != (
            rec.get("input_size"),
            rec.get("input_mtime_ns"),
        ):
            return False
        if os.path.getsize(task.output) != rec.get("output_size"):
            return False
        return sha256_file(task.output) == rec.get("output_sha256")
    except OSError:
        return False


# -- running ---------------------------------------------------------------------------


def memory_budget() -> int:
    """Half the physical memory, in bytes."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") // 2
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return 4 << 30


def estimate_nbytes(task: Task) -> int:
    """Memory one task needs: ``MEMORY_FACTOR`` times its voxel bytes (0 if unknown)."""
    import numpy as np

    from . import io as vio

    try:
        if task.kind == "decompress":
            from .format.container import Reader

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
    from .parallel import parse_workers

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
        records.get(i)
        or {"input": t.input, "output": t.output, "status": "cancelled", "error": None}
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
        "mb_per_s": done_raw / 1e6 / max(seconds, 1e-9),
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
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return f"{kind} x{workers}"


def _run_dask(todo, scheduler, workers, processes, on_result, state, func) -> str:
    from distributed import as_completed

    from .parallel import dask_client

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
    from .format.atomic import atomic_open

    with atomic_open(path, force=True) as f:
        f.write(json.dumps(finite_json(report), indent=2, sort_keys=True, allow_nan=False).encode())
