"""What a command says on stderr while it works, so that no run is silent for long.

- The first time kernels compile for this source tree (an empty cache), one line says
  what is happening, about how long it takes and that ``volpack warmup`` does it ahead.
- When stderr is not a terminal (CI logs, pipes, ``nohup``) there is no progress bar, so
  a line every few seconds says what the command is doing: compiling kernels, or how far
  its task is. Nothing is printed for a command that ends within the first interval.
"""

from __future__ import annotations

import sys
import threading
import time

INTERVAL = 5.0
FIRST_RUN = (
    "volpack: first run of this volpack (a new version or source tree has an empty "
    "kernel cache): compiling numba kernels ({what}); a command "
    "compiles only the kernels it uses, about 1-2 min for the first compress, once: they "
    "are cached in {where}. 'volpack warmup' compiles them all ahead."
)


class Notices:
    def __init__(self, stream=None, *, quiet: bool = False, interval: float = INTERVAL):
        self.stream = stream or sys.stderr
        self.quiet = quiet
        self.lines = not quiet and not _isatty(self.stream)
        self.interval = interval
        self._t0 = time.perf_counter()
        self._compiling = 0  # compilations under way (nested ones count)
        self._compiled = 0
        self._compile_s = 0.0
        self._told = False
        self._task: tuple[str, str, int, int] | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()

    # -- sources of news ---------------------------------------------------------------

    def on_compile(self, event: str, name: str, seconds: float | None) -> None:
        from .. import jitwatch

        with self._lock:
            if event == "start":
                self._compiling += 1
                first = not self._told and jitwatch.fresh_cache and not self.quiet
                self._told = self._told or bool(first)
            else:
                self._compiling = max(self._compiling - 1, 0)
                if self._compiling == 0:
                    self._compile_s += seconds or 0.0
                self._compiled += 1
                first = False
        if first:
            self._say(FIRST_RUN.format(what=name, where=jitwatch.cache_dir or "memory"))
        self._ensure_thread()

    def task(self, desc: str, unit: str):
        """A ``progress(done, total)`` callback that feeds the periodic lines."""

        def update(done: int, total: int) -> None:
            self._task = (desc, unit, int(done), int(total))
            self._ensure_thread()

        return update

    def end_task(self) -> None:
        self._task = None

    # -- the periodic line -------------------------------------------------------------

    def status(self) -> str | None:
        t = time.perf_counter() - self._t0
        with self._lock:
            compiling, compiled = self._compiling, self._compiled
        if compiling:
            return f"volpack: {t:.0f} s: compiling kernels ({compiled} compiled so far)"
        if self._task is not None:
            desc, unit, done, total = self._task
            of = f"/{total}" if total else ""
            return f"volpack: {t:.0f} s: {desc} {done}{of} {unit}{'s' if total != 1 else ''}"
        return None

    def _ensure_thread(self) -> None:
        if self.lines and self._thread is None:
            self._thread = threading.Thread(target=self._run, name="volpack-notices", daemon=True)
            self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(self.interval):
            line = self.status()
            if line:
                self._say(line)

    def _say(self, line: str) -> None:
        try:
            print(line, file=self.stream, flush=True)
        except (OSError, ValueError):  # a closed or broken stderr: stay quiet
            pass

    def close(self) -> None:
        self._stop.set()
        from .. import jitwatch

        jitwatch.unsubscribe(self.on_compile)


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def install(ctx, quiet: bool) -> Notices:
    """Start the notices for this command (stopped when the command's context closes)."""
    from .. import jitwatch

    n = Notices(quiet=quiet)
    jitwatch.subscribe(n.on_compile)
    ctx.call_on_close(n.close)
    ctx.obj["notices"] = n
    return n
