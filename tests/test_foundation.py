"""Volume model, atomic output, the brick grid, ordered and as-completed parallel maps, the JIT cache policy."""

from __future__ import annotations

import contextlib
import itertools
import os
import signal
import subprocess
import sys
import threading

import numpy as np
import pytest

from volpack.errors import FormatError
from volpack.format.atomic import OutputExistsError, atomic_dir, atomic_open, check_output
from volpack.parallel import completed_map, ordered_map
from volpack.volume import Volume
from volpack.volume_codec import bricks


def test_volume_checks_and_describe():
    v = Volume(np.arange(24, dtype=np.int16).reshape(2, 3, 4), spacing=(2, 1, 1))
    d = v.describe()
    assert (
        d["shape"] == [2, 3, 4]
        and d["min"] == 0
        and d["max"] == 23
        and d["spacing"] == [2.0, 1.0, 1.0]
    )
    with pytest.raises(FormatError, match="found an array of shape"):
        Volume(np.zeros((3, 4)))
    with pytest.raises(FormatError, match="positive spacing"):
        Volume(np.zeros((1, 1, 1)), spacing=(1, 0, 1))
    with pytest.raises(FormatError, match="mask shape"):
        Volume(np.zeros((1, 1, 2)), mask=np.zeros((1, 1, 1), bool))
    f = Volume(np.array([[[1.0, np.nan, np.inf]]]))
    assert f.describe()["nan"] == 1 and f.describe()["max"] == 1.0


def test_atomic_dir_leaves_nothing_while_another_thread_still_writes(tmp_path):
    # zarr writes from its own thread, which an interrupt does not stop: files it added
    # while the failed write's folder was being removed left the folder behind
    stop = threading.Event()

    def writer(folder):
        for i in range(40):  # as zarr's store does: the parents made for each chunk
            with contextlib.suppress(OSError):  # (the folder removed under it)
                os.makedirs(os.path.join(folder, "c", str(i)), exist_ok=True)
                with open(os.path.join(folder, "c", str(i), "0"), "wb") as f:
                    f.write(bytes(4096))
            if stop.wait(0.005):
                return

    with pytest.raises(KeyboardInterrupt):
        with atomic_dir(tmp_path / "v.zarr") as tmp:
            t = threading.Thread(target=writer, args=(tmp,))
            t.start()
            raise KeyboardInterrupt
    stop.set()
    t.join()
    assert os.listdir(tmp_path) == []


def test_atomic_open_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "out.bin"
    with pytest.raises(RuntimeError):
        with atomic_open(target) as f:
            f.write(b"partial")
            raise RuntimeError("boom")
    assert os.listdir(tmp_path) == []
    with atomic_open(target) as f:
        f.write(b"whole")
    assert target.read_bytes() == b"whole"
    plain = tmp_path / "plain.bin"
    plain.write_bytes(b"")  # the mode an ordinary open gives, umask applied
    assert os.stat(target).st_mode & 0o777 == os.stat(plain).st_mode & 0o777
    plain.unlink()
    with pytest.raises(OutputExistsError, match="force=True"):
        with atomic_open(target) as f:
            f.write(b"again")
    assert target.read_bytes() == b"whole"
    with pytest.raises(OutputExistsError, match="input"):
        check_output(target, force=True, inputs=(str(target),))


def test_a_killed_writer_leaves_no_file(tmp_path):
    code = (
        "import os, signal, sys\n"
        "from volpack.format.atomic import atomic_open\n"
        "with atomic_open(sys.argv[1]) as f:\n"
        "    f.write(b'x' * 100000); f.flush()\n"
        "    os.kill(os.getpid(), signal.SIGKILL)\n"
    )
    r = subprocess.run([sys.executable, "-c", code, str(tmp_path / "o.vpk")], check=False)
    assert r.returncode == -signal.SIGKILL
    assert os.listdir(tmp_path) == []


def test_a_dead_writers_part_file_is_removed_by_the_next_write(tmp_path):
    from volpack.format import atomic

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True).stdout.strip()  # fmt: skip
    left = tmp_path / f".volpack-{dead}-0123abcd.part"
    mine = tmp_path / f".volpack-{os.getpid()}-0123abcd.part"  # a live writer's
    left.write_bytes(b"half")
    mine.write_bytes(b"busy")
    with atomic.atomic_path(tmp_path / "o.h5") as p:
        open(p, "wb").close()
    assert sorted(os.listdir(tmp_path)) == [mine.name, "o.h5"]


def test_an_output_in_a_missing_folder_is_named_in_the_error(tmp_path):
    target = tmp_path / "no" / "o.vpk"
    with pytest.raises(FileNotFoundError) as e:
        with atomic_open(target) as f:
            f.write(b"x")
    assert e.value.filename == str(target)


def test_brick_grid_covers_every_voxel_once():
    shape, brick = (17, 5, 33), (8, 8, 16)
    seen = np.zeros(shape, dtype=np.int32)
    nodes = []
    for node, sl in bricks.iter_bricks(shape, brick):
        seen[sl] += 1
        assert bricks.brick_slices(shape, brick, node) == sl
        nodes.append(node)
    assert (seen == 1).all() and nodes == list(range(len(nodes)))
    assert bricks.grid_shape(shape, brick) == (3, 1, 3)


def test_bricks_in_roi_matches_brute_force():
    shape, brick = (20, 9, 30), (8, 4, 7)
    for roi in [
        (slice(0, 20), slice(0, 9), slice(0, 30)),
        (slice(7, 9), slice(3, 5), slice(13, 15)),
        (slice(19, 20), slice(8, 9), slice(29, 30)),
    ]:
        want = [
            n
            for n, sl in bricks.iter_bricks(shape, brick)
            if all(s.start < r.stop and r.start < s.stop for s, r in zip(sl, roi))
        ]
        assert bricks.bricks_in_roi(shape, brick, roi) == want


def test_ordered_map_keeps_order_with_threads():
    items = list(range(200))
    for w in (1, 2, 5):
        assert list(ordered_map(lambda i: i * i, items, w)) == [i * i for i in items]
    assert list(ordered_map(lambda i: i, itertools.islice(itertools.count(), 10), 3)) == list(
        range(10)
    )


def test_completed_map_runs_past_a_slow_item():
    # item 0 waits for the last one: the in-order map (look-ahead 4 x 2) never submits
    # it while 0 is pending; the as-completed map does, on the other worker
    import threading

    last = threading.Event()

    def fn(i):
        if i == 0:
            return last.wait(timeout=20)
        if i == 29:
            last.set()
        return i

    got = list(completed_map(fn, range(30), 2))
    assert sum(g is True for g in got) == 1 and sorted(g for g in got if g is not True) == list(range(1, 30))
    assert list(completed_map(lambda i: -i, range(5), 1)) == [0, -1, -2, -3, -4]


def test_completed_map_raises_a_helper_error_and_stops_early():
    # the caller's thread works too: an error on either thread reaches the caller, and
    # closing the generator early leaves the remaining items untaken
    import threading

    def boom(i):
        if i == 7:
            raise ValueError("item 7")
        return i

    with pytest.raises(ValueError, match="item 7"):
        list(completed_map(boom, range(40), 3))
    taken = []
    lock = threading.Lock()

    def note(i):
        with lock:
            taken.append(i)
        return i

    gen = completed_map(note, range(1000), 2, ahead=2)  # the helper waits with 4 results
    first = [next(gen) for _ in range(3)]
    gen.close()
    assert len(set(first)) == 3 and len(taken) < 1000
    assert sorted(completed_map(lambda i: i * 3, range(50), 2)) == [3 * i for i in range(50)]


def test_jit_cache_dir_follows_the_sources(tmp_path):
    code = "import volpack._jit as j; print(j.cache_dir())"
    env = dict(os.environ, VOLPACK_CACHE_DIR=str(tmp_path))
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env
    )
    path = out.stdout.strip()
    assert path.startswith(str(tmp_path)) and len(os.path.basename(path)) == 16


_YAML = """
import sys
import volpack._jit as j
config = j.numba.core.config
print("yaml" in sys.modules, config.BOUNDSCHECK)
open(".numba_config.yaml", "w").write("boundscheck: 1\\n")
config.reload_config()  # what numba does before a compile
print("yaml" in sys.modules, config.BOUNDSCHECK)
"""


def test_numba_config_file_read_with_yaml_imported_on_demand(tmp_path):
    # numba is imported without PyYAML where no .numba_config.yaml is in the working
    # directory (16 ms of every process); one found later is still read, and one present
    # at the start is read at the import, as numba reads them
    pytest.importorskip("yaml")
    import volpack

    env = {k: v for k, v in os.environ.items() if k != "NUMBA_BOUNDSCHECK"}
    env["PYTHONPATH"] = os.path.dirname(os.path.dirname(volpack.__file__))  # this tree, from cwd
    run = [sys.executable, "-c", _YAML]
    out = subprocess.run(run, cwd=tmp_path, capture_output=True, text=True, check=True, env=env)
    assert out.stdout.split("\n")[:2] == ["False None", "True 1"]
    out = subprocess.run(run, cwd=tmp_path, capture_output=True, text=True, check=True, env=env)
    assert out.stdout.split("\n")[:2] == ["True 1", "True 1"]  # the file left by the first run


_EXTENSIONS = """
import sys
import volpack._jit as j
j.numba.core.entrypoints.init_all()  # what numba calls before a kernel's first compile or load
print("importlib.metadata" in sys.modules, j.numba.core.entrypoints._already_initialized)
"""


def _numba_extensions_run(tmp_path, extra_path=None):
    import volpack

    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [os.path.dirname(os.path.dirname(volpack.__file__))] + ([str(extra_path)] if extra_path else [])))  # fmt: skip
    out = subprocess.run([sys.executable, "-c", _EXTENSIONS], cwd=tmp_path, capture_output=True,
                         text=True, check=True, env=env)  # fmt: skip
    return out.stdout.split("\n")[0]


def test_numba_extensions_listed_without_importlib_metadata_where_none_is_declared(tmp_path):
    # numba lists the numba_extensions entry points of every distribution before its
    # first compile or load (importlib.metadata: 11 ms to import, 3 ms to list); where no
    # entry_points.txt names the group, the listing is empty without it
    from importlib import metadata

    if metadata.entry_points().select(group="numba_extensions"):
        pytest.skip("a numba extension is installed here")
    assert _numba_extensions_run(tmp_path) == "False True"


def test_numba_extension_declared_by_a_distribution_is_still_loaded(tmp_path):
    # a distribution on the path that declares one: numba lists and runs it as before
    dist = tmp_path / "site" / "fakeext-1.0.dist-info"
    dist.mkdir(parents=True)
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: fakeext\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[numba_extensions]\ninit = fakeext:init\n")
    mark = tmp_path / "loaded"
    (tmp_path / "site" / "fakeext.py").write_text(
        f"def init():\n    open({str(mark)!r}, 'w').write('ok')\n")  # fmt: skip
    assert _numba_extensions_run(tmp_path, tmp_path / "site") == "True True"
    assert mark.read_text() == "ok"


def test_llvm_lock_events_quiet_on_this_thread_only():
    # a kernel's load calls into LLVM hundreds of times without numba's llvm_lock events
    # (QUIET_LLVM); other threads, and this one outside it, still broadcast them
    from llvmlite import binding as ll
    from numba.core import event

    from volpack._jit import QUIET_LLVM

    def calls():
        ll.parse_assembly("define i32 @f() {\n  ret i32 1\n}\n").verify()

    class Threads(event.Listener):  # the thread of each event
        def __init__(self):
            self.names = []

        def on_start(self, ev):
            self.names.append(threading.current_thread().name)

        def on_end(self, ev):
            self.names.append(threading.current_thread().name)

    outside, quiet = Threads(), Threads()
    with event.install_listener("numba:llvm_lock", outside):
        calls()
    with event.install_listener("numba:llvm_lock", quiet), QUIET_LLVM():
        calls()
        th = threading.Thread(target=calls)
        th.start()
        th.join()
    assert len(outside.names) >= 4 and len(quiet.names) == len(outside.names)
    assert set(quiet.names) == {th.name}  # none from this thread


_INLINED = """
import hashlib, re
import numpy as np
from volpack import _jit
from volpack._jit import kernel

@kernel(inline=True)
def _step(a, i, s):
    if a[i] > s:
        s = s + a[i] * 3
    else:
        s = s - (a[i] >> 1)
    return s

@kernel(inline=True)
def _twice(a, i, s):
    return _step(a, i, _step(a, i, s))

def _outer(a):
    s = np.int64(0)
    for i in range(a.size):
        s = _twice(a, i, s)
        if s > 1000:
            s = _step(a, i, s) % 997
    return s

import numba
outer = numba.njit(_outer)
a = np.arange(50, dtype=np.int64) * 7 % 13
v = outer(a)
asm = re.sub(r"_ZN\\w+", "", outer.inspect_asm(outer.signatures[0]))
print(v, _jit._inline_copies["applied"], hashlib.sha256(asm.encode()).hexdigest())
"""


def test_shared_inline_copies_compile_the_same_machine_code():
    # volpack's cheaper copying in numba's inliner must leave the compiled code as it is:
    # the same kernel (three levels of inlined helpers) with and without it
    outs = []
    for mode in ("share", "numba"):
        env = dict(os.environ, VOLPACK_INLINE_COPY=mode, VOLPACK_JIT_CACHE="0")
        run = subprocess.run([sys.executable, "-c", _INLINED], capture_output=True, text=True,
                             check=True, env=env)  # fmt: skip
        outs.append(run.stdout.split())
    (v1, on, asm1), (v2, off, asm2) = outs
    assert off == "False" and v1 == v2 and asm1 == asm2
    if on != "True":  # a numba whose inliner changed shape: its own copying is kept
        pytest.skip("numba's inliner is not the shape volpack._jit expects; copies left to numba")


def _inlined_helper(a, i):
    return a[i] * 2 + 1


def test_inline_into_inlines_a_helper_into_the_named_kernel_only():
    """``inline_into``: the helper's body in the named kernel (no call to it in its
    LLVM), a call in the other; both compute the same."""
    import numba

    from volpack._jit import JIT_DISABLED, inline_into

    if JIT_DISABLED:
        pytest.skip("no compiled code without the JIT")
    helper = numba.njit(inline=inline_into("inlining_caller"))(_inlined_helper)

    def inlining_caller(a):
        return helper(a, 0) + helper(a, 1)

    def calling_caller(a):
        return helper(a, 0) + helper(a, 1)

    a = np.arange(5, dtype=np.int64)
    inl, call = numba.njit(inlining_caller), numba.njit(calling_caller)
    assert inl(a) == call(a) == 4
    name = "_inlined_helper"
    assert name not in "".join(inl.inspect_llvm().values())
    assert name in "".join(call.inspect_llvm().values())


_CACHED_KERNELS = '''
import numba
import numpy as np
from volpack._jit import kernel

@kernel
def ramp(n):  # allocates: links against the NRT
    return np.arange(n) * 2

@kernel
def hashed(s):  # string hashing: links against numba's hash secret symbols
    return hash(s) == hash(s + "")

@kernel(parallel=True)
def total(a):  # a parallel loop: its threading layer starts on load
    s = 0.0
    for i in numba.prange(a.size):
        s += a[i]
    return s
'''

_LOAD = """
import sys
import threading
import numpy as np
sys.path.insert(0, sys.argv[1])
import kmod
out = [int(kmod.ramp(5).sum()), bool(kmod.hashed("volpack")), float(kmod.total(np.ones(100)))]
hits = [sum(k._cache_hits.values()) for k in (kmod.ramp, kmod.hashed, kmod.total)]
loaded = "numba.np.arraymath" in sys.modules or "numba.typed.dictimpl" in sys.modules
out.append(float(kmod.total(np.ones(10, sys.argv[2]))))  # a new signature: compiled here
print(out, hits, loaded, "numba.np.arraymath" in sys.modules)
"""


@pytest.mark.slow  # compiles a parallel kernel twice in processes of its own (10 s)
def test_cached_kernels_load_without_the_compilers_registries(tmp_path):
    # A process that finds its kernels in the cache links their machine code without
    # importing what numba compiles with; a new signature then still compiles
    (tmp_path / "kmod.py").write_text(_CACHED_KERNELS)
    env = dict(os.environ, VOLPACK_CACHE_DIR=str(tmp_path / "cache"))
    env.pop("VOLPACK_JIT_CACHE", None)
    runs = [subprocess.run([sys.executable, "-c", _LOAD, str(tmp_path), dtype],
                           capture_output=True, text=True, check=True, env=env).stdout.split("] ")
            for dtype in ("float32", "int32")]  # fmt: skip
    (first, hits1, rest1), (second, hits2, rest2) = runs
    assert first == second == "[20, True, 100.0, 10.0" and hits1 == "[0, 0, 0"
    from volpack._jit import JIT_DISABLED, _KERNEL_CACHE

    if JIT_DISABLED or _KERNEL_CACHE is None:
        pytest.skip("kernels load numba's way (no JIT, or numba's cache has another shape)")
    assert hits2 == "[1, 1, 1" and rest2.split() == ["False", "True"]


def test_cached_only_refuses_to_compile():
    # a helper thread that loads kernels ahead (render.rehearse) must never compile: under
    # cached_only a dispatcher without the signature raises NotCached, compiling nothing,
    # and runs what it has
    from volpack._jit import JIT_DISABLED, NotCached, cached_only, numba

    if JIT_DISABLED:
        pytest.skip("no JIT: nothing compiles")

    @numba.njit
    def plus_one(x):
        return x + 1

    with pytest.raises(NotCached), cached_only():
        plus_one(1)
    assert plus_one.signatures == []
    assert plus_one(2) == 3  # outside: compiles as usual
    with cached_only():
        assert plus_one(4) == 5  # compiled already: runs
        with pytest.raises(NotCached):
            plus_one(1.5)  # another signature
    assert len(plus_one.signatures) == 1
    seen = []  # another thread compiles meanwhile: the flag is this thread's only
    with cached_only():
        th = threading.Thread(target=lambda: seen.append(plus_one(2.5)))
        th.start()
        th.join()
    assert seen == [3.5]


def test_workers_left_to_volpack_are_capped_by_tasks_and_memory(monkeypatch):
    from volpack import parallel
    from volpack.volume_codec import stream

    monkeypatch.setattr(parallel, "default_workers", lambda: 8)
    monkeypatch.setattr(parallel, "memory_budget", lambda: 3 << 30)
    assert parallel.auto_workers(3) == 3 and parallel.auto_workers(0) == 1
    assert parallel.auto_workers(100, 1 << 30) == 3 and parallel.auto_workers(100, 8 << 30) == 1
    per = stream.ENCODE_BYTES_PER_VOXEL
    # 2 x 4 x 4 bricks of 64^3 (64 MB each at 256 B a voxel): the cores cap
    assert stream._encode_workers(0, (128, 256, 256), (64, 64, 64)) == 8
    assert stream._encode_workers(None, (2, 40, 64, 64), (64, 64, 64)) == 2  # two frames
    n = (3 << 30) // (128**3 * per)  # bricks of 128^3: the memory caps
    assert stream._encode_workers(0, (512, 512, 512), (128, 128, 128)) == max(1, min(8, n))
    assert stream._encode_workers(3, (8, 8, 8), (64, 64, 64)) == 3  # asked: as asked


def test_compress_and_decompress_use_the_cores_by_default(tmp_path):
    import json

    from click.testing import CliRunner

    from volpack.cli import main

    vol = np.random.default_rng(0).integers(0, 4000, (8, 64, 96), dtype=np.uint16)
    np.save(tmp_path / "v.npy", vol)
    out = {}
    for j in ("1", None):
        args = ["compress", str(tmp_path / "v.npy"), str(tmp_path / f"v{j}.vpk"), "--json"]
        args += ["--brick", "8,32,32"] + (["-j", j] if j else [])
        r = CliRunner().invoke(main, args)
        assert r.exit_code == 0, r.output
        out[j] = json.loads(r.stdout)["workers"]
    assert out["1"] == 1 and out[None] == min(parallel_cores(), 6)
    assert (tmp_path / "v1.vpk").read_bytes() == (tmp_path / "vNone.vpk").read_bytes()
    r = CliRunner().invoke(main, ["decompress", str(tmp_path / "vNone.vpk"), str(tmp_path / "b.npy")])
    assert r.exit_code == 0 and np.array_equal(np.load(tmp_path / "b.npy"), vol), r.output


def parallel_cores() -> int:
    from volpack.parallel import default_workers

    return default_workers()
