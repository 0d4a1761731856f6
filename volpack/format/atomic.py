"""Atomic output: write to a temporary file beside the target, then give it the name.

A crash, a full disk or an exception half way leaves the target as it was (absent or
the old file) and no partial file behind. On Linux the temporary file has no name at
all (``O_TMPFILE``) and is linked into the folder only when complete, so even a killed
process leaves nothing. Elsewhere (and for writers that need a file name) it is
``.volpack-<pid>-<random>.part``; the next write into that folder removes such files
whose writer is gone. An existing target is replaced only when the caller says so, and
never when it is one of the inputs. Errors name the target, not the temporary file.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import secrets
import shutil
import signal
import sys
import threading
import time
from collections.abc import Iterator
from typing import BinaryIO

from ..errors import VolpackError


class OutputExistsError(VolpackError, FileExistsError):
    """The output exists and overwriting was not asked for."""


def check_output(path: str | os.PathLike, *, force: bool = False, inputs: tuple = ()) -> None:
    """Raise if writing ``path`` would overwrite an input, or an existing file without ``force``."""
    p = os.fspath(path)
    if p == "-":
        return
    for inp in inputs:
        ip = os.fspath(inp).split(":/")[0] if isinstance(inp, str) else os.fspath(inp)
        if ip != "-" and os.path.exists(ip) and os.path.exists(p) and os.path.samefile(ip, p):
            raise OutputExistsError(
                f"refusing to overwrite the input {ip!r}; choose another output"
            )
    if os.path.exists(p) and not force:
        raise OutputExistsError(f"output {p!r} exists; pass force=True to replace it")


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike, *, force: bool = False) -> Iterator[BinaryIO]:
    """Open ``path`` for binary writing so that it appears whole or not at all.

    ``'-'`` yields standard output's binary buffer (streams cannot be atomic; the
    caller writes in one pass).
    """
    p = os.fspath(path)
    if p == "-":
        yield sys.stdout.buffer
        sys.stdout.buffer.flush()
        return
    check_output(p, force=force)
    directory = os.path.dirname(os.path.abspath(p))
    fd, tmp = _open_unnamed(directory, p)
    try:
        with os.fdopen(fd, "wb") as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
            if tmp is None:
                tmp = _link(f.fileno(), directory, p, force)
        if tmp is not None:
            os.chmod(tmp, _default_mode())  # a named temporary file is made 0600
            _rename(tmp, p)
    except BaseException as e:
        if tmp is not None:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
        named = write_error(e, p) if isinstance(e, OSError) else e
        if named is not e:
            raise named from None
        raise


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, *, force: bool = False, suffix: str = "") -> Iterator[str]:
    """Yield a temporary path beside ``path`` for libraries that want a file name
    (h5py, nibabel, tifffile); it is renamed onto ``path`` when the block succeeds."""
    p = os.fspath(path)
    check_output(p, force=force)
    directory = os.path.dirname(os.path.abspath(p))
    _sweep(directory, p)
    tmp = _part_name(directory, suffix or ".part")  # not created: some writers refuse one
    try:
        yield tmp
        _rename(tmp, p)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def atomic_dir(path: str | os.PathLike, *, force: bool = False) -> Iterator[str]:
    """Yield a temporary folder beside ``path`` for outputs that are folders (a zarr
    store); it takes the name ``path`` when the block succeeds, and an existing folder of
    that name (``force``) is removed only after that."""
    p = os.fspath(path)
    check_output(p, force=force)
    directory = os.path.dirname(os.path.abspath(p))
    _sweep(directory, p)
    tmp = _part_name(directory, ".part")
    old = None
    try:
        os.mkdir(tmp)  # (inside: an interrupt just after it is cleaned up below)
        yield tmp
        if os.path.isdir(p) and not os.path.islink(p):
            old = _part_name(directory, ".old")  # never swept: killed here, it is kept
            os.rename(p, old)
        _rename(tmp, p)
    except BaseException:
        if old is not None and not os.path.exists(p):
            os.rename(old, p)  # the earlier output back under its name
        _remove_tree(tmp)
        raise
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def _remove_tree(path: str, quiet: float = 0.05, limit: float = 2.0) -> None:
    """Remove a temporary folder that a library's own thread may still be writing into
    (zarr's event loop goes on with the chunks of a call that failed, making their
    folders again): removed until it has stayed away for ``quiet`` seconds, for up to
    ``limit`` seconds."""
    end = time.monotonic() + limit
    while True:
        shutil.rmtree(path, ignore_errors=True)
        time.sleep(quiet)
        if not os.path.lexists(path) or time.monotonic() > end:
            return


@contextlib.contextmanager
def interrupts_deferred() -> Iterator[None]:
    """Hold back Ctrl-C (SIGINT) until the block ends, then raise it as usual: for a
    short write done in another thread, which the interrupt would not stop. Only the main
    thread receives signals; elsewhere (or when Python does not handle SIGINT) the block
    runs as it is."""
    old = signal.getsignal(signal.SIGINT)
    if threading.current_thread() is not threading.main_thread() or not callable(old):
        yield
        return
    got: list[int] = []
    signal.signal(signal.SIGINT, lambda signum, frame: got.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
    if got:
        old(signal.SIGINT, None)  # Python's default handler raises KeyboardInterrupt


# errors of a write, which name no file: a full disk, a quota, a file size limit
_WRITE_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)

_PART = re.compile(r"\.volpack-(\d+)-[0-9a-f]{8}\.")


def _part_name(directory: str, suffix: str) -> str:
    return os.path.join(directory, f".volpack-{os.getpid()}-{secrets.token_hex(4)}{suffix}")


def _open_unnamed(directory: str, target: str) -> tuple[int, str | None]:
    """An unnamed file in ``directory`` (``O_TMPFILE``), or a named ``.part`` file where
    the system or the file system has none."""
    try:
        if hasattr(os, "O_TMPFILE"):
            try:
                return os.open(directory, os.O_TMPFILE | os.O_WRONLY, 0o666), None
            except OSError as e:
                if e.errno not in (errno.EOPNOTSUPP, errno.EISDIR, errno.EINVAL, errno.ENOSYS):
                    raise
        _sweep(directory, target)
        tmp = _part_name(directory, ".part")
        return os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600), tmp
    except OSError as e:
        raise _naming(e, target) from None


def _link(fd: int, directory: str, target: str, force: bool) -> str | None:
    """Give the unnamed file ``fd`` the name ``target``: directly when there is no file
    of that name, else a ``.part`` name that the caller renames over the old file."""
    # linkat(AT_SYMLINK_FOLLOW) of /proc/self/fd/N; a dir_fd makes Python call linkat
    # (plain link() would link the /proc symlink itself)
    proc = os.open("/proc/self/fd", os.O_RDONLY)
    try:
        if not os.path.lexists(target):
            try:
                os.link(str(fd), target, src_dir_fd=proc, follow_symlinks=True)
                return None
            except FileExistsError:
                if not force:
                    raise
        tmp = _part_name(directory, ".part")
        os.link(str(fd), tmp, src_dir_fd=proc, follow_symlinks=True)
        return tmp
    except OSError as e:
        raise _naming(e, target) from None
    finally:
        os.close(proc)


def _rename(tmp: str, target: str) -> None:
    try:
        os.replace(tmp, target)
    except OSError as e:
        raise _naming(e, target) from None


def write_error(e: OSError, target: str | None) -> OSError:
    """``e`` naming ``target`` where it is a failed write, which names no file (a full
    disk: "[Errno 28] No space left on device", not which output); else ``e`` itself."""
    if target is None or e.filename is not None or e.errno not in _WRITE_ERRNOS:
        return e
    return _naming(e, target)


def _naming(e: OSError, target: str) -> OSError:
    """The same error, naming the target the caller asked for."""
    return type(e)(e.errno, e.strerror, target) if e.errno is not None else e


def _sweep(directory: str, target: str) -> None:
    """Remove ``.part`` files in ``directory`` left by volpack writers that are gone."""
    try:
        names = os.listdir(directory)
    except OSError:
        return
    for name in names:
        m = _PART.match(name)
        if m is None or name.endswith(".old") or _alive(int(m.group(1))):
            continue  # an ``.old`` folder is an earlier output a killed atomic_dir set aside
        part = os.path.join(directory, name)
        with contextlib.suppress(OSError):
            if os.path.isdir(part) and not os.path.islink(part):  # an atomic_dir's
                shutil.rmtree(part)
            else:
                os.unlink(part)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, OSError):
        return True
    return True


def _default_mode() -> int:
    """Permissions a newly created file gets from ``open``: 0666 less the umask."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask
