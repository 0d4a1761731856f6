"""The only module that imports numba.

Kernel modules import :func:`kernel` from here at their top, so numba is loaded when a
kernel module is first imported, never by ``volpack --help`` or ``import volpack``.

Compiled kernels are cached on disk. numba keys its cache to the file that defines a
kernel only, so an edit to a callee in another file (or an upgrade of volpack) would
reuse stale machine code. The cache directory is therefore named after a hash of every
source file of the package: any change to the sources starts a fresh cache.

Environment:

``VOLPACK_JIT_CACHE=0``
    compile in memory only, write nothing.
``VOLPACK_CACHE_DIR``
    parent of the cache directory (default ``$XDG_CACHE_HOME/volpack`` or
    ``~/.cache/volpack``).
``NUMBA_DISABLE_JIT=1``
    numba's own switch: kernels run as plain Python (slow; used by tests to check the
    compiled kernels against their interpreted selves).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import pathlib
import sys
import threading
import types

import numpy as np


def _import_numba():
    """Import numba without two optional imports it makes at load and rarely uses:

    * scipy, which numba imports only to refuse a SciPy older than 1.0 (for its
      SciPy-based features, which no kernel here uses), 10-20 ms: hidden for the import;
      scipy imports normally afterwards;
    * PyYAML, which numba's config imports to read a ``.numba_config.yaml`` in the
      working directory, 16 ms of every process: where there is no such file, numba's
      config gets :class:`_YamlOnDemand` instead, so that a file found later (numba
      reads the config again before each compile) is read as numba would read it;
    * ``importlib.metadata``, which numba imports to list the ``numba_extensions``
      entry points of every installed distribution before its first compile or cache
      load (11 ms to import, 3 ms to list 99 distributions): numba gets
      :class:`_MetadataOnDemand`, which looks for the group's name in the distributions'
      ``entry_points.txt`` first and hands the listing to ``importlib.metadata`` only
      where one may declare it.
    """
    if "numba" in sys.modules:
        import numba

        return numba
    hidden = [m for m in ("scipy", "yaml") if m not in sys.modules]
    if "yaml" in hidden and (os.path.exists(".numba_config.yaml") or not _installed("yaml")):
        hidden.remove("yaml")  # numba reads the file now (or warns that it cannot)
    for m in hidden:
        sys.modules[m] = None  # an ImportError for numba's import
    metadata = None if "importlib.metadata" in sys.modules else _MetadataOnDemand()
    if metadata is not None:
        sys.modules["importlib.metadata"] = metadata  # what numba.core.entrypoints binds
    try:
        import numba
    finally:
        for m in hidden:
            del sys.modules[m]
        if metadata is not None and sys.modules.get("importlib.metadata") is metadata:
            del sys.modules["importlib.metadata"]  # others import the real one
    if "yaml" in hidden:
        numba.core.config.yaml = _YamlOnDemand()
        numba.core.config._HAVE_YAML = True
    return numba


def _installed(name: str) -> bool:
    import importlib.util

    return importlib.util.find_spec(name) is not None


class _YamlOnDemand:
    """What numba's config calls of PyYAML, importing it on the first call."""

    @staticmethod
    def safe_load(stream):
        import yaml

        return yaml.safe_load(stream)


class _MetadataOnDemand(types.ModuleType):
    """``importlib.metadata`` as numba's entry-point loader uses it: ``entry_points()``
    is an empty listing where no distribution can declare ``numba_extensions`` (numba
    then loads none, as it would), else the real listing; any other name is the real
    module's."""

    def __init__(self) -> None:
        super().__init__("importlib.metadata")

    def entry_points(self, **params):
        if not params and not _may_declare(b"numba_extensions"):
            return _NoEntryPoints()
        return self._real().entry_points(**params)

    def __getattr__(self, name):
        return getattr(self._real(), name)

    def _real(self):
        if sys.modules.get("importlib.metadata") is self:
            del sys.modules["importlib.metadata"]
        import importlib.metadata

        return importlib.metadata


class _NoEntryPoints:
    """An empty ``EntryPoints`` as numba reads it."""

    def select(self, **params):
        return ()


def _may_declare(word: bytes) -> bool:
    """Whether some distribution that ``importlib.metadata`` would find may declare an
    entry point with ``word`` in its ``entry_points.txt``: True for anything this does
    not read as importlib does (a finder of distributions besides the path finder, a
    zip or an egg on the path, a file it cannot read)."""
    import importlib.machinery

    for finder in sys.meta_path:
        if hasattr(finder, "find_distributions") and finder is not importlib.machinery.PathFinder:
            return True
    for entry in sys.path:
        root = entry or "."
        if not os.path.isdir(root):
            if os.path.exists(root):  # a zip: importlib reads its members
                return True
            continue
        try:
            names = os.listdir(root)
        except OSError:
            return True
        for name in names:
            low = name.lower()
            if low.endswith(".egg"):
                return True
            if not low.endswith((".dist-info", ".egg-info")):
                continue
            path = os.path.join(root, name, "entry_points.txt")
            try:
                with open(path, "rb") as f:
                    if word in f.read():
                        return True
            except FileNotFoundError:
                continue
            except OSError:
                return True
    return False


numba = _import_numba()

CACHE = os.environ.get("VOLPACK_JIT_CACHE", "1") != "0"
_PACKAGE = pathlib.Path(__file__).resolve().parent


def source_hash() -> str:
    """Return a short hash of every ``.py`` file of the package (names and contents)."""
    h = hashlib.sha256()
    for p in sorted(_PACKAGE.rglob("*.py")):
        h.update(str(p.relative_to(_PACKAGE)).encode())
        h.update(p.read_bytes())
    h.update(numba.__version__.encode())
    return h.hexdigest()[:16]


def cache_dir() -> pathlib.Path:
    """Return the directory compiled kernels of this exact source tree are cached in."""
    base = os.environ.get("VOLPACK_CACHE_DIR")
    if not base:
        xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        base = os.path.join(xdg, "volpack")
    return pathlib.Path(base) / "jit" / source_hash()


if CACHE and not os.environ.get("NUMBA_CACHE_DIR"):
    numba.config.CACHE_DIR = str(cache_dir())


class NotCached(RuntimeError):
    """A kernel that :func:`cached_only` forbade to compile (it is not in the cache for
    the arguments it was called with)."""


_only_cached = threading.local()


def _compiling_forbidden() -> bool:
    return getattr(_only_cached, "on", False)


@contextlib.contextmanager
def cached_only():
    """On this thread, a kernel that would compile raises :class:`NotCached` instead;
    cached kernels load as usual. For work done ahead on a helper thread to load
    kernels off the main thread (:mod:`volpack.render.rehearse`): compiling there would
    hold numba's compiler lock and the GIL for seconds and could not pay off."""
    before = _compiling_forbidden()
    _only_cached.on = True
    try:
        yield
    finally:
        _only_cached.on = before


def _watch_compiles() -> None:
    """Forward numba's compile events to :mod:`volpack.jitwatch` (the CLI's notices)."""
    import time

    from numba.core import event

    from . import jitwatch

    where = pathlib.Path(numba.config.CACHE_DIR) if CACHE else None
    jitwatch.cache_dir = str(where) if where else None
    jitwatch.fresh_cache = where is None or not where.is_dir() or not any(where.iterdir())

    class _Listener(event.Listener):
        def __init__(self):
            self._t0: list[float] = []

        def _name(self, ev) -> str:
            fn = getattr(ev.data.get("dispatcher"), "py_func", None)
            return getattr(fn, "__qualname__", "?")

        def on_start(self, ev):
            if _compiling_forbidden():  # any dispatcher, cached on disk or not
                self._t0.append(None)
                raise NotCached(f"{self._name(ev)} is not compiled for these arguments")
            _share_inline_copies()
            self._t0.append(time.thread_time())  # CPU: wall time would count the neighbours
            jitwatch.notify("start", self._name(ev))

        def on_end(self, ev):
            t0 = self._t0.pop() if self._t0 else time.thread_time()
            if t0 is None:  # refused by cached_only: nothing compiled
                return
            dt = time.thread_time() - t0
            jitwatch.notify("end", self._name(ev), dt)

    event.register("numba:compile", _Listener())


def _share_inline_copies() -> None:
    """Make numba's IR inliner copy a callee's blocks with one memo per inlining.

    For every ``inline=True`` call site numba deep-copies each block of the callee with a
    memo of its own, and each block's copy takes a copy of the whole scope (every
    variable of the callee) along: the cost grows with blocks times variables, and was
    most of the compile time of the kernels built from many inlined helpers (predictive
    decoder: 58 % under cProfile). With one memo for the blocks of one inlining, the
    copies share one scope, as the callee's blocks do. The IR is the same; only the
    copying is cheaper (numba issues 8989 and 9204 discuss the same copies).
    Applied on the first compile only (a process that loads cached kernels never imports
    the inliner), and only if numba's inliner has the shape this was written for;
    ``VOLPACK_INLINE_COPY=numba`` leaves numba as it is."""
    if _inline_copies["done"]:
        return
    _inline_copies["done"] = True
    if os.environ.get("VOLPACK_INLINE_COPY") == "numba":
        return
    import copy

    from numba.core import inline_closurecall as icc
    from numba.core import ir

    worker = getattr(icc, "InlineWorker", None)
    if getattr(icc, "copy", None) is not copy or not hasattr(worker, "inline_ir"):
        return
    memos: dict[int, tuple[dict, set]] = {}  # id(source scope) -> (memo, ids of copied blocks)
    depth = [0]

    class _Copy:
        """``copy`` as the inliner sees it: a block copied while an inlining runs
        shares the memo of the blocks of the same scope, until a block repeats (the
        next copy of the same callee starts afresh)."""

        def __getattr__(self, name):
            return getattr(copy, name)

        @staticmethod
        def deepcopy(x, memo=None):
            if memo is None and depth[0] and isinstance(x, ir.Block):
                memo, seen = memos.get(id(x.scope)) or ({}, set())
                if id(x) in seen:
                    memo, seen = {}, set()
                memos[id(x.scope)] = (memo, seen)
                seen.add(id(x))
            return copy.deepcopy(x, memo)

    inline_ir = worker.inline_ir

    def _inline_ir(self, *args, **kwargs):
        depth[0] += 1
        try:
            return inline_ir(self, *args, **kwargs)
        finally:
            depth[0] -= 1
            if not depth[0]:
                memos.clear()  # nothing outlives an inlining (ids are not reused meanwhile)

    icc.copy = _Copy()
    worker.inline_ir = _inline_ir
    _inline_copies["applied"] = True


_inline_copies = {"done": False, "applied": False}

_watch_compiles()


def _numpy_support_without_scipy() -> None:
    """Load numba's NumPy support (the registries every compile sets up) without
    scipy.linalg: numba imports it only to learn whether ``np.dot`` may call BLAS,
    which no kernel here does, and the import took 0.5-0.7 s of every process that
    set numba's compiler up (about half of numba's set-up). scipy.linalg is hidden
    for this one import only; it imports normally afterwards."""
    if "numba.np.arraymath" in sys.modules or "scipy.linalg" in sys.modules:
        return
    sys.modules["scipy.linalg"] = None  # an ImportError for numba's probe
    try:
        import numba.np.arraymath  # noqa: F401
    finally:
        del sys.modules["scipy.linalg"]


JIT_DISABLED = bool(numba.config.DISABLE_JIT)


def _kernel_cache_class():
    """numba's on-disk cache of one kernel, changed in two ways that cost nothing but time:

    * *set up on first use*: numba builds a kernel's cache when it is decorated, which
      checks the cache directory by creating a temporary file in it, once per kernel of
      every imported module (80-odd for a render that runs seven: about 10 ms);
    * *loading no compiler*: before each load numba refreshes the compiler's registries
      (``BaseContext.refresh``: importing and installing the typing and lowering code of
      everything numba compiles: unicode, sets, lists, random, typed containers...),
      0.10-0.15 s of a process's first load. Machine code read from the cache needs none
      of it, only the symbols it links against: the NRT's (``rtsys.initialize``) and
      the hash secrets (``numba.cpython.hashing``), both made ready here, and the C
      helpers and math functions numba registers when it is imported. A miss loads
      numba's NumPy support (:func:`_numpy_support_without_scipy`) and refreshes as
      numba does, and so does every compile (``CompilerBase``).

    * *without LLVM's lock events*: numba broadcasts an event on entering and on leaving
      every call into LLVM (``numba:llvm_lock``, to time a compile), and a load makes
      100-400 such calls, reading its module's symbols one by one; without the events
      the 22 loads before a walk's first frame took 14-33 ms less. A load makes its
      calls on its own thread without them (:func:`_quiet_llvm_events`).

    None (plain ``cache=True``) when numba's cache has not the shape this was written for.
    """
    from numba.core import caching
    from numba.core.runtime import rtsys

    base = getattr(caching, "FunctionCache", None)
    if base is None or not all(
        hasattr(base, a) for a in ("_load_overload", "_guard_against_spurious_io_errors")
    ):
        return None

    quiet = QUIET_LLVM

    class KernelCache(base):
        def __init__(self, py_func):  # numba's __init__ runs on first use (_ready)
            self._py_func = py_func
            self._name = repr(py_func)

        def _ready(self):
            if "_impl" not in self.__dict__:
                base.__init__(self, self._py_func)
            return self

        @property
        def cache_path(self):
            return self._ready()._cache_path

        def load_overload(self, sig, target_context):
            self._ready()
            with quiet():
                rtsys.initialize(target_context)
                import numba.cpython.hashing  # noqa: F401  (its symbols, for code that hashes)

                with self._guard_against_spurious_io_errors():
                    cres = self._load_overload(sig, target_context)
            if cres is None and _compiling_forbidden():  # before the compiler's set-up
                raise NotCached(f"{self._name} is not in the kernel cache for {sig}")
            if cres is None:  # a miss compiles next: numba's own order
                _numpy_support_without_scipy()
                target_context.refresh()
            return cres

        def save_overload(self, sig, data):
            self._ready()
            return base.save_overload(self, sig, data)

        def enable(self):
            self._ready()._enabled = True

        def disable(self):
            self._ready()._enabled = False

        def flush(self):
            self._ready()._cache_file.flush()

    return KernelCache


def _quiet_llvm_events():
    """A context manager under which this thread's calls into LLVM broadcast none of
    numba's ``numba:llvm_lock`` events (see :func:`_kernel_cache_class`). Only a compile
    listens to them, to record its LLVM time in its metadata, and a load holds the
    compiler lock, so no compile runs meanwhile. numba's callbacks are wrapped, once,
    not removed: a call another thread is inside of leaves as it entered."""
    from llvmlite.binding import ffi

    cbs = getattr(getattr(getattr(ffi, "lib", None), "_lock", None), "_cblist", None)
    if not isinstance(cbs, list):  # not the llvmlite this was written for
        return contextlib.nullcontext
    off = threading.local()

    def unless_quiet(fn):
        def callback():
            if not getattr(off, "on", False):
                fn()

        return callback

    cbs[:] = [(unless_quiet(enter), unless_quiet(leave)) for enter, leave in cbs]

    @contextlib.contextmanager
    def quiet():
        before = getattr(off, "on", False)
        off.on = True
        try:
            yield
        finally:
            off.on = before

    return quiet


QUIET_LLVM = _quiet_llvm_events()
_KERNEL_CACHE = None if JIT_DISABLED or not CACHE else _kernel_cache_class()
if _KERNEL_CACHE is None:  # every kernel compiles here, or loads numba's way
    _numpy_support_without_scipy()

if JIT_DISABLED:

    def leading_zeros(x):
        """Count of leading zero bits of a 64-bit unsigned integer (64 for zero)."""
        return 64 - int(x).bit_length()

else:  # LLVM's ctlz: one instruction where the CPU has it
    from numba.cpython.unsafe.numbers import leading_zeros  # noqa: F401


def kernel(
    fn=None, /, *, parallel: bool = False, inline: bool = False, nrt: bool = True,
    contract: bool = False,
):  # fmt: skip
    """Decorate a kernel: nopython, nogil, cached on disk, no fastmath (bit-exact).

    ``nrt=False`` compiles without numba's reference counting: the kernel may not
    allocate arrays (its caller passes them in), and in exchange its loops carry no
    reference-count calls. Inlined helpers that take arrays otherwise leave such calls
    in hot loops (measured: a third of the predictive decoder's time).

    ``inline`` may also be :func:`inline_into`'s choice: inlined into some kernels only.

    ``contract=True`` lets LLVM fuse a multiply and an add into one FMA instruction (one
    rounding instead of two): the result may differ in the last bit between CPUs with
    and without FMA, never between runs or thread counts on one CPU. Only for kernels
    whose output is an image, never bytes (the ray caster's march: 12-15 % faster).
    """
    if fn is None:
        return functools.partial(
            kernel, parallel=parallel, inline=inline, nrt=nrt, contract=contract
        )
    disp = numba.njit(
        fn,
        cache=CACHE and _KERNEL_CACHE is None,
        nogil=True,
        parallel=parallel,
        inline=inline if callable(inline) else ("always" if inline else "never"),
        error_model="numpy",
        fastmath={"contract"} if contract else False,
        _nrt=nrt,
    )
    if _KERNEL_CACHE is not None:
        disp._cache = _KERNEL_CACHE(disp.py_func)  # what enable_caching() sets, lazier
    return disp


def inline_into(*names):
    """An ``inline`` for :func:`kernel`: the helper is inlined where the kernel being
    compiled is one of ``names`` and called elsewhere. numba inlines before it prunes
    branches, so a helper inlined everywhere is compiled into kernels where it is dead
    code (the interpolation walk's adaptive bin reader: half a minute per kernel)."""

    def cost_model(_expr, caller_ir, _callee_ir):
        return caller_ir.func_id.func_name in names

    return cost_model


def read_only(a):
    """A read-only view of array ``a``. numba compiles a kernel once for writable and
    once more for read-only arrays (a file read through the CLI arrives read-only, an
    array from the API writable); kernels that only read a volume get it through here,
    so both callers share one compiled signature (and the first render after an API
    call compiles nothing new)."""
    v = np.asarray(a).view()
    v.flags.writeable = False
    return v


def prange(*args):
    """numba's parallel range (a plain ``range`` when the JIT is disabled)."""
    return numba.prange(*args)
