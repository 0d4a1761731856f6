"""What a command says on stderr while it works, so that no run is silent for long.

- The first time kernels compile for this source tree (an empty cache), one line says
  what is happening, about how long it takes and that ``volpack warmup`` does it ahead.
- When stderr is not a terminal (CI logs, pipes, ``nohup``) there is no progress bar, so
  a line every few seconds says what the command is doing: compiling kernels, or how far
  its task is. Nothing is printed for a command that ends within the first interval.
- A step with nothing to count (reading or writing a whole file, preparing a render) is
  a *phase*: the same periodic line names it, and on a terminal one line, redrawn every
  second and erased at its end, says what is going on and for how long.
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time
from collections.abc import Iterator

INTERVAL = 5.0
TTY_INTERVAL = 1.0  # a phase's line on a terminal is redrawn this often
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
        self.tty = not quiet and not self.lines
        self.interval = interval
        self._t0 = time.perf_counter()
        self._compiling = 0  # compilations under way (nested ones count)
        self._compiled = 0
        self._compile_s = 0.0
        self._told = False
        self._task: tuple[str, str, int, int] | None = None
        self._phase: tuple[str, float] | None = None  # (what, when it began)
        self._drawn = False  # a phase's line is on the terminal
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
            self._task = (desc, unit, int(done), int(total or 0))  # None: not known
            self._ensure_thread()

        return update

    def end_task(self) -> None:
        self._task = None

    @contextlib.contextmanager
    def phase(self, what: str) -> Iterator[None]:
        """A step with nothing to count ('writing ct.nii.gz'), named while it lasts."""
        self._phase = (what, time.perf_counter())
        if self.lines or self.tty:
            self._ensure_thread(self.tty)
        try:
            yield
        finally:
            with self._lock:
                self._phase = None
                if self._drawn:
                    self._draw("")

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
        if self._phase is not None:
            return f"volpack: {t:.0f} s: {self._phase[0]}"
        return None

    def _ensure_thread(self, tty: bool = False) -> None:
        if (self.lines or tty) and self._thread is None:
            self._thread = threading.Thread(target=self._run, name="volpack-notices", daemon=True)
            self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(self.interval if self.lines else TTY_INTERVAL):
            if self.lines:
                line = self.status()
                if line:
                    self._say(line)
                continue
            with self._lock:  # a terminal: the phase's own line, in place
                if self._phase is not None:
                    what, t0 = self._phase
                    self._draw(f"volpack: {what} ({time.perf_counter() - t0:.0f} s)")

    def _draw(self, line: str) -> None:
        """Put ``line`` in place of the phase's line on the terminal ('' erases it)."""
        try:
            self.stream.write(f"\r{line}\x1b[K")
            self.stream.flush()
            self._drawn = bool(line)
        except (OSError, ValueError):
            pass

    def _say(self, line: str) -> None:
        try:
            print(line, file=self.stream, flush=True)
        except (OSError, ValueError):  # a closed or broken stderr: stay quiet
            pass

    def close(self) -> None:
        self._stop.set()
        with self._lock:
            if self._drawn:
                self._draw("")
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
