"""A resident volpack: ``volpack serve`` keeps numba and the kernels loaded, and the
``volpack`` command hands it the commands that gain from that.

A new process pays about half a second before it can render anything (numba's import,
its runtime set up, the cached kernels linked: README, "The whole process against a VTK
script"); a preview takes a few tenths more. With a server listening, ``volpack render``
sends its arguments over a Unix socket, the server runs them in its warm process and
sends back the exit code and what the command printed; the client itself imports
nothing of numpy or numba.

What is shared and what is not. Only code stays resident: every request reads its
files, builds its tables and writes its output as a fresh process would (a test checks
the bytes against a local run), so nothing about a file is remembered from one request
to the next. Requests run one at a time, in the client's working directory and with its
umask.

When the client runs the command itself instead:

* no server for this exact install is listening: the socket's name carries a stamp of
  the package's sources (their sizes and modification times), the Python and the
  ``VOLPACK_*``/``NUMBA_*`` environment, so an edited tree, another venv or other
  settings never reach a server started before them;
* the command is not one of :data:`SERVED`, reads standard input or writes standard
  output (``-``), or asks for ``--help``/``--version``;
* ``VOLPACK_SERVE=0`` is set, or the server ends without answering.

Security: the socket lives in a directory only its owner can enter (``0700``, checked),
and the server answers only its own user (``SO_PEERCRED`` where the platform has it).
The protocol: JSON objects, one a line, each capped at :data:`MAX_MESSAGE` bytes: the
request; then the command's stderr as it is written (``{"err": ...}``), and last its
exit code with its stdout (``{"code": ..., "out": ...}``).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import socket
import stat
import sys
import time
from pathlib import Path

PROTOCOL = 1
SERVED = frozenset({"render", "info", "walk", "play"})  # previews: start-up is much of their time
MAX_MESSAGE = 64 << 20  # a reply carries what the command printed; more is an error
CONNECT_TIMEOUT = 1.0
_PACKAGE = Path(__file__).resolve().parent
_GLOBAL_FLAGS = frozenset({"-v", "-vv", "--verbose", "-q", "--quiet", "--debug"})
_LOCAL_FLAGS = frozenset({"-h", "--help", "--version"})


def stamp() -> str:
    """What a server must share with a client to answer it: this install's sources (names,
    sizes, modification times), the Python running it and the volpack/numba settings in
    the environment. 16 hex digits; about 1 ms for the package's files."""
    h = hashlib.sha256(f"{PROTOCOL}\0{sys.executable}\0{sys.version}\0".encode())
    for root, dirs, files in os.walk(_PACKAGE):
        dirs.sort()
        for name in sorted(files):
            if name.endswith(".py"):
                st = os.stat(os.path.join(root, name))
                h.update(f"{root}/{name}\0{st.st_size}\0{st.st_mtime_ns}\0".encode())
    for key in sorted(os.environ):
        if key.startswith(("VOLPACK_", "NUMBA_")) and not key.startswith("VOLPACK_SERVE"):
            h.update(f"{key}={os.environ[key]}\0".encode())
    return h.hexdigest()[:16]


def socket_dir(create: bool = False) -> Path:
    """``$VOLPACK_SERVE_DIR``, else ``$XDG_RUNTIME_DIR/volpack``, else
    ``~/.cache/volpack/serve``; made ``0700`` when ``create``. A directory that others may
    enter, or that another user owns, is refused (:class:`~volpack.errors.OptionError`)."""
    base = os.environ.get("VOLPACK_SERVE_DIR")
    if base:
        d = Path(base)
    elif os.environ.get("XDG_RUNTIME_DIR"):
        d = Path(os.environ["XDG_RUNTIME_DIR"]) / "volpack"
    else:
        d = Path.home() / ".cache" / "volpack" / "serve"
    if create:
        d.mkdir(mode=0o700, parents=True, exist_ok=True)
    return d


def _private(d: Path) -> bool:
    try:
        st = os.stat(d)
    except OSError:
        return False
    return stat.S_ISDIR(st.st_mode) and st.st_uid == os.getuid() and not st.st_mode & 0o077


def socket_path() -> Path:
    """The socket a server of this install (:func:`stamp`) listens on."""
    return socket_dir() / f"volpack-{stamp()}.sock"


_client_started: float | None = None  # while a server runs a request: its client's start


def _process_started() -> float | None:
    """When this process started, in ``CLOCK_BOOTTIME`` seconds (from /proc, 10 ms
    resolution), or None where there is no /proc."""
    try:
        with open("/proc/self/stat") as f:
            ticks = int(f.read().rsplit(")", 1)[1].split()[19])  # field 22, starttime
        return ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, AttributeError):
        return None


def started() -> float | None:
    """When the process a user waits on started (``CLOCK_BOOTTIME`` seconds): the
    client's while a server runs its request, else this process's; None if unknown."""
    return _client_started if _client_started is not None else _process_started()


# -- client ------------------------------------------------------------------------


def served_command(argv: list[str]) -> str | None:
    """The command ``argv`` runs if a server may run it, else None (see the module)."""
    i = 0
    while i < len(argv) and argv[i] in _GLOBAL_FLAGS:
        i += 1
    if i == len(argv) or argv[i] not in SERVED:
        return None
    if any(a == "-" or a in _LOCAL_FLAGS for a in argv):
        return None
    return argv[i]


def forward(argv: list[str]) -> int | None:
    """Run ``argv`` (the words after ``volpack``) in a listening server of this install
    and return its exit code, having written what it printed; None where the caller must
    run the command itself."""
    if os.environ.get("VOLPACK_SERVE") == "0" or not hasattr(socket, "AF_UNIX"):
        return None
    if served_command(argv) is None:
        return None
    d = socket_dir()
    path = d / f"volpack-{stamp()}.sock"
    if not path.exists() or not _private(d):
        return None
    umask = os.umask(0o022)  # read it (there is no other way), then put it back
    os.umask(umask)
    request = {"v": PROTOCOL, "argv": argv, "cwd": os.getcwd(), "stamp": path.stem[8:],
               "umask": umask, "started": _process_started()}  # fmt: skip
    reply = None
    try:
        with _connect(path) as s:
            _send(s, request)
            for message in _messages(s):  # what the command says on stderr, as it says it
                if "code" in message or "error" in message:
                    reply = message
                    break
                _write(sys.stderr, message.get("err"))
    except OSError:
        return None  # stale socket, refused: run here
    if reply is None or not isinstance(reply.get("code"), int):
        return None  # the server ended without answering, or refused the request
    _write(sys.stdout, reply.get("out"))
    return reply["code"]


def _write(stream, text) -> None:
    if isinstance(text, str) and text:
        try:
            stream.write(text)
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: the command itself goes on
            pass


def _connect(path: Path | None) -> socket.socket:
    """A socket connected to the server on ``path`` (default: this install's), blocking
    from then on; OSError where nothing listens (no file, or a stale one: refused)."""
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        s.settimeout(CONNECT_TIMEOUT)
        s.connect(str(path or socket_path()))
        s.settimeout(None)  # a long request under way is not a dead server
    except OSError:
        s.close()
        raise
    return s


def stop(path: Path | None = None) -> bool:
    """Ask the server on ``path`` (default: this install's) to exit, once the request it
    runs (if any) is done; False if none listens."""
    try:
        with _connect(path) as s:
            _send(s, {"v": PROTOCOL, "stop": True})
            return _receive(s) is not None
    except OSError:
        return False


def listening(path: Path | None = None) -> bool:
    """Whether a server listens on ``path`` (default: this install's socket): it takes
    the connection, even while it runs a request (a server that died leaves a socket
    file that refuses it)."""
    try:
        with _connect(path):
            return True
    except OSError:
        return False


def _send(s: socket.socket, message: dict) -> None:
    s.sendall(json.dumps(message).encode() + b"\n")


def _messages(s: socket.socket):
    """The JSON objects the peer sends, one a line, each at most :data:`MAX_MESSAGE`
    bytes; ends where the peer closes, or sends a longer line or one that is not a JSON
    object."""
    with s.makefile("rb") as f:
        while True:
            line = f.readline(MAX_MESSAGE + 1)
            if not line.endswith(b"\n"):
                return
            try:
                message = json.loads(line)
            except ValueError:
                return
            if not isinstance(message, dict):
                return
            yield message


def _receive(s: socket.socket) -> dict | None:
    """The first message of :func:`_messages`, or None."""
    return next(_messages(s), None)


class _Relay(io.TextIOBase):
    """A command's stderr in a server: each write goes to the client at once (notices,
    progress lines, errors), so a long request is not silent. Writes may come from the
    command's threads too."""

    def __init__(self, conn: socket.socket):
        import threading

        self.conn = conn
        self.lock = threading.Lock()
        self.gone = False

    def writable(self) -> bool:
        return True

    def write(self, text) -> int:
        if isinstance(text, (bytes, bytearray)):  # a writer that found no text layer
            text = bytes(text).decode("utf-8", "replace")
        if text and not self.gone:
            with self.lock:
                try:
                    _send(self.conn, {"err": text})
                except OSError:
                    self.gone = True  # the client left (interrupted): the command goes on
        return len(text)


# -- server ------------------------------------------------------------------------


def serve(
    runner,
    path: Path | None = None,
    *,
    idle: float = 1800.0,
    warm: bool = True,
    log=None,
    ready=None,
) -> int:
    """Listen on ``path`` (default :func:`socket_path`) and run requests one at a time
    until ``idle`` seconds pass without one (0: never) or a client asks it to stop.
    ``runner(argv)`` runs one command line as the ``volpack`` command does and ends by
    raising ``SystemExit`` with its code (the CLI passes click's standalone ``main``).
    ``warm`` loads the ray caster's kernels for the common dtypes first (from the kernel
    cache; compiling them on an empty cache). Returns the number of commands run."""
    from .errors import OptionError

    if not hasattr(socket, "AF_UNIX"):
        raise OptionError("volpack serve needs Unix sockets, which this platform lacks")
    own = stamp()  # of the code this process loads; later edits never reach it
    if path is None:
        path = socket_dir(create=True) / f"volpack-{own}.sock"
    if not _private(path.parent):
        raise OptionError(
            f"{path.parent}: expected a directory only you can enter (mode 0700), "
            "found one others can enter or owned by another user"
        )
    if listening(path):
        raise OptionError(f"a volpack server already listens on {path}")
    log = log or (lambda line: None)
    if warm:
        t = time.perf_counter()
        for line in _warm(runner, own):
            log(f"warming failed: {line}")
        log(f"kernels loaded in {time.perf_counter() - t:.1f} s")
    if warm and listening(path):  # another server started while this one warmed
        raise OptionError(f"a volpack server already listens on {path}")
    with contextlib.suppress(FileNotFoundError):
        path.unlink()  # a stale socket of a server that died
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        server.bind(str(path))
    except OSError:
        server.close()  # another server bound it first: its socket is not ours to remove
        raise OptionError(f"a volpack server already listens on {path}") from None
    served = 0
    _exit_on_sigterm()
    try:
        os.chmod(path, 0o600)
        server.listen(16)
        server.settimeout(idle or None)
        log(f"listening on {path}")
        if ready is not None:
            ready()
        while True:
            try:
                conn, _ = server.accept()
            except TimeoutError:
                log(f"idle for {idle:g} s: exiting")
                break
            with conn:
                if not _same_user(conn):
                    continue
                conn.settimeout(30.0)  # a client sends its request at once
                try:
                    request = _receive(conn)
                except OSError:
                    continue
                if not isinstance(request, dict) or request.get("v") != PROTOCOL:
                    _reply(conn, {"error": "expected a volpack request of protocol 1"})
                    continue
                if request.get("stop"):
                    _reply(conn, {"stopped": True})
                    log("asked to stop")
                    break
                reply = _run(runner, request, own, _Relay(conn))
                served += reply.get("code") is not None
                _reply(conn, reply)
                if reply.get("code") is not None:
                    log(f"{' '.join(request['argv'][:2])}: exit {reply['code']}")
    finally:
        server.close()
        with contextlib.suppress(FileNotFoundError):
            path.unlink()
    return served


class Terminate(BaseException):
    """SIGTERM in a server: not an exception of the command it was running."""


def _exit_on_sigterm() -> None:
    """``kill`` ends the server through its ``finally`` (the socket removed), as Ctrl-C
    does; only the main thread may set a handler (a server in a thread keeps Python's)."""
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():

        def terminate(signum, frame):
            raise Terminate(signum)

        signal.signal(signal.SIGTERM, terminate)


def _same_user(conn: socket.socket) -> bool:
    if not hasattr(socket, "SO_PEERCRED"):
        return True  # the socket's directory is private
    import struct

    creds = conn.getsockopt(socket.SOL_SOCKET, socket.SO_PEERCRED, struct.calcsize("3i"))
    _pid, uid, _gid = struct.unpack("3i", creds)
    return uid == os.getuid()


def _reply(conn: socket.socket, message: dict) -> None:
    try:
        _send(conn, message)
    except OSError:
        pass  # the client went away (interrupted): its answer is lost, nothing else


def _valid(request: dict, own: str) -> str | None:
    argv, cwd = request.get("argv"), request.get("cwd")
    if not isinstance(argv, list) or not all(isinstance(a, str) for a in argv):
        return "expected argv as a list of strings"
    if served_command(argv) is None:
        return f"expected one of the served commands {sorted(SERVED)}, found {argv[:2]}"
    if not isinstance(cwd, str) or not os.path.isdir(cwd):
        return f"expected an existing working directory, found {cwd!r}"
    if request.get("stamp") != own:
        return "stale: this server belongs to another install or environment"
    return None


def _run(runner, request: dict, own: str, err=None) -> dict:
    """Run one command as ``volpack ARGV`` would in ``cwd``, if the request carries this
    server's stamp ``own``: what it printed on stdout is returned, its stderr goes to
    ``err`` (a :class:`_Relay`), else is returned too."""
    problem = _valid(request, own)
    if problem is not None:
        return {"code": None, "error": problem}
    import gc
    import logging

    out = io.StringIO()
    kept = err is None
    err = io.StringIO() if kept else err
    try:
        here = os.getcwd()
    except OSError:  # the server's own folder was removed
        here = "/"
    try:
        os.chdir(request["cwd"])
    except OSError as e:  # removed since: the client runs the command itself
        return {"code": None, "error": f"cannot work in {request['cwd']}: {e.strerror}"}
    umask = request.get("umask")
    mask = os.umask(umask if isinstance(umask, int) and 0 <= umask <= 0o777 else 0o022)
    global _client_started
    t0 = request.get("started")
    _client_started = float(t0) if isinstance(t0, (int, float)) and t0 >= 0 else None
    root = logging.getLogger()
    handlers = root.handlers[:]
    root.handlers.clear()  # each command configures logging onto its own stderr
    code: int = 0
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                runner(request["argv"])
            except SystemExit as e:  # click's standalone mode always ends this way
                code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
                if code == 1 and not isinstance(e.code, int):
                    print(e.code, file=sys.stderr)
            except (KeyboardInterrupt, Terminate):
                raise  # the server is asked to end: the client gets no answer, runs it itself
            except BaseException as e:  # noqa: BLE001  (a server survives its commands)
                print(f"volpack: internal error, please report: {type(e).__name__}: {e}",
                      file=sys.stderr)  # fmt: skip
                from .errors import EXIT_INTERNAL

                code = EXIT_INTERNAL
    finally:
        _client_started = None
        with contextlib.suppress(OSError):
            os.chdir(here)
        os.umask(mask)
        root.handlers[:] = handlers
        gc.collect()
    reply = {"code": code, "out": out.getvalue()}
    if kept:
        reply["err"] = err.getvalue()
    return reply


def _warm(runner, own: str) -> list[str]:
    """Load the kernels a first preview of each common dtype needs: render a small
    sphere of uint8, int16, uint16 and float32, shaded and not, into a scratch folder.
    Returns what failed (nothing, unless volpack is broken)."""
    import tempfile

    import numpy as np

    from .api import write_volume
    from .volume import Volume

    failed: list[str] = []
    z, y, x = np.mgrid[:20, :20, :20]
    ball = 100.0 * np.exp(-((z - 9.5) ** 2 + (y - 9.5) ** 2 + (x - 9.5) ** 2) / 40.0)
    with tempfile.TemporaryDirectory(prefix="volpack-serve-") as d:
        for dtype in ("uint8", "int16", "uint16", "float32"):
            src = os.path.join(d, f"{dtype}.npy")
            write_volume(Volume(ball.astype(dtype)), src)
            for shading in ("none", "phong"):
                reply = _run(runner, {"argv": ["-q", "render", src, os.path.join(d, "out.png"),
                                               "--force", "--size", "32x32", "--shading", shading],
                                      "cwd": d, "stamp": own}, own)  # fmt: skip
                if reply["code"] != 0:
                    lines = (reply.get("err") or reply.get("error") or "").strip().splitlines()
                    failed.append(f"{dtype} {shading}: {lines[-1] if lines else reply['code']}")
    return failed
