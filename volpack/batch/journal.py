"""The resume journal of a batch (see :mod:`volpack.batch`): what each output was made
from and holds, appended one fsync'd JSON line per task."""

import hashlib
import json
import os
import time
from typing import Any

from ..jsonsafe import jsonable
from .planning import Task


def input_stat(spec: str) -> dict[str, int]:
    """Size and mtime of an input (a folder: the sum and latest of its files)."""
    from ..io import parse_spec

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
        "lossless",
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
        self._f.write(json.dumps(jsonable(line), sort_keys=True) + "\n")
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
