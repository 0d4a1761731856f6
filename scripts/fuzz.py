"""Mutation fuzzer: damaged ``.vpk`` streams through every decode path of the CLI.

Every stream kind has a seed (the golden examples in ``formats/examples/``, plus a float
volume with NaN made here). Each mutant is one of

* ``raw``: bytes flipped, set, inserted, deleted or cut off anywhere in the file;
* ``payload``: one chunk's payload changed, then the file rewritten so that every
  checksum matches again (what a decoder sees when damage passes the CRCs);
* ``header``: one field of the JSON header (or summary) replaced by another type or an
  extreme value, or removed, checksums recomputed,

and runs through one decode path of its kind (``decompress``, ``--roi``, ``--frame``,
``--level``, ``--error``, ``info``, ``render``, ``play``, ``walk``, standard input) in a
forked child of a worker, with an address-space limit (``RLIMIT_AS``) and a wall-clock
limit. Every path runs once in the parent first, so workers and children inherit compiled
kernels; runs write into ``/dev/shm`` where there is one (no disk flush per output).
Outcomes:

* ``error``: exit 1 with a one-line ``volpack: error:`` (what damage must give);
* ``same``: decoded, output identical to the undamaged stream's;
* ``silent``: decoded without error to a different output (damage accepted silently);
* ``internal`` (exit 3: an exception volpack did not raise on purpose), ``signal``,
  ``timeout``, ``usage`` (exit 2) and ``other``: failures; their files are kept under
  ``OUT/failures/`` with the command line and the error text.

Writes ``OUT/summary.csv`` (one row per kind and mutation) and prints a markdown table.

    python scripts/fuzz.py --count 2000                  # results/fuzz/
    python scripts/fuzz.py --count 100000 --seed 7 --workers 2 --out /tmp/fuzz
    python scripts/fuzz.py --count 240 --seconds 40 --seed 1 --out /tmp/f  # tests/test_fuzz.py
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import csv
import gc
import hashlib
import io
import os
import pathlib
import random
import resource
import shutil
import signal
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "formats" / "examples"

VOLUME_PATHS = ("decompress", "roi", "info", "render", "stdin")
KINDS = {
    "arith": ("wavelet-53-arith-dfs-u8.vpk", VOLUME_PATHS),
    "arith2": ("wavelet-53-arith2-dfs-u8.vpk", VOLUME_PATHS),
    # not wavelet-53-huffman-dfs-i16: seven of its eight bricks are stored raw (noise)
    "huffman": ("wavelet-haar-huffman-dfs-u8.vpk", VOLUME_PATHS),
    "lossy-nan": (None, VOLUME_PATHS),
    # the default lossless codec (per brick: prediction, palette, labels), the table-coded
    # fast codec, and the lossy path that predicts quantised voxels by interpolation
    "lossless": ("lossless-auto-u8.vpk", VOLUME_PATHS),
    # predictive version 2 (fitted predictor, background mask): the default since a8c957f
    "lossless-v2": ("lossless-v2-u8-mask.vpk", VOLUME_PATHS),
    # version 5's low-value models (flag 64) under a noise floor
    "lossless-v5": ("lossless-v5-u8-floor.vpk", VOLUME_PATHS),
    # version 7's texture bias (flag 128)
    "lossless-v7": ("lossless-v7-u8-tex.vpk", VOLUME_PATHS),
    # version 8's mixed estimates (flag 256, a second flags byte)
    "lossless-v8": ("lossless-v8-u8-mix.vpk", VOLUME_PATHS),
    # mode 6 (session 34): bricks shrunk to one slice a run of repeated slices
    "lossless-repeat": ("lossless-v8-u8-repeat.vpk", VOLUME_PATHS),
    # mode 7 (session 37): a brick that is its own mirror image, coded as its first half
    "lossless-mirror": ("lossless-v8-u8-mirror.vpk", VOLUME_PATHS),
    # mode 8 (session 38): a gain comb, the counts and the residues coded apart
    "lossless-gain": ("lossless-v8-i16-gain.vpk", VOLUME_PATHS),
    # LOWM (session 39): the low-value class's mantissa bits keyed on the prediction
    "lossless-lowm": ("lossless-v8-u8-lowm.vpk", VOLUME_PATHS),
    # version 9's local fit (flag 512 in the second flags byte), with a mask and palette
    "lossless-v9": ("lossless-v9-u8-local.vpk", VOLUME_PATHS),
    "lossless-v9-mask": ("lossless-v9-u8-local-mask.vpk", VOLUME_PATHS),
    # version 3's float tools (mode 5): Lorenzo on the floats' signed images, and lattices
    "float-lorenzo": ("lossless-v3-f32-smooth.vpk", VOLUME_PATHS),
    "float-lattice": ("lossless-v3-f32-packed.vpk", VOLUME_PATHS),
    # version 4's float blend (mode 5, tool 2): copies from two periods
    "float-blend": ("lossless-v4-f32-periodic.vpk", VOLUME_PATHS),
    # version 6's fitted float predictor (mode 5, tool 3): 23 float32 weights, specials
    "float-fit": ("lossless-v6-f32-fit.vpk", VOLUME_PATHS),
    # version 10's box fit in tool 3 (predictor byte 8 + P: a shape and K more weights)
    "float-fit-box": ("lossless-v10-f32-fit-box.vpk", VOLUME_PATHS),
    "fast": ("fast-u8-background.vpk", VOLUME_PATHS),
    # the fast codec's run mode (the default since the `runs` header field)
    "fast-runs": ("fast-runs-mixed.vpk", VOLUME_PATHS),
    # its row kinds (the default since the `rows` header field): copy runs of rows
    "fast-rows": ("fast-rows-labels.vpk", VOLUME_PATHS),
    # its zstd bricks (mode 3, the default since the `zstd` header field), beside the others
    "fast-zstd": ("fast-zstd-mixed.vpk", VOLUME_PATHS),
    "lossy-interp": ("lossy-bounded-f32-interp.vpk", VOLUME_PATHS),
    # effort 'fast' on integers: the quantised voxels as a fast codec payload (inner byte 6)
    "lossy-fast-int": ("lossy-bounded-i16-fast.vpk", VOLUME_PATHS),
    # ... and of floats, with the mask of a fill value
    "lossy-fast-float": ("lossy-bounded-f32-fast.vpk", VOLUME_PATHS),
    # ... and the interpolation path's grouped bins (kind bit 5), with raw bits
    "lossy-fast-bins": ("lossy-bounded-f32-fastbins-raw.vpk", VOLUME_PATHS),
    # ... and its static bins with tables shared between contexts (kind bit 6)
    "lossy-interp-shared": ("lossy-bounded-f32-interp-shared.vpk", VOLUME_PATHS),
    # ... and the exact path's lattices with their integers by the fast codec (step 19b)
    "lossy-fast-exact": ("lossy-bounded-f32-levels-fast.vpk", VOLUME_PATHS),
    # the float wavelet path: Mallat layout with the outlier bin field, and separable
    "lossy-cdf97": ("lossy-bounded-f32-cdf97-bins.vpk", VOLUME_PATHS),
    "lossy-separable": ("lossy-bounded-f32-separable.vpk", VOLUME_PATHS),
    # the quantised voxels by the long fitted predictor: its payload's version 1 and 2
    "lossy-longfit": ("lossy-bounded-f32-longfit.vpk", VOLUME_PATHS),
    "lossy-longfit-reach": ("lossy-bounded-f32-longfit-reach.vpk", VOLUME_PATHS),
    # and version 2's residual by the adaptive coder in activity contexts (type 3)
    "lossy-longfit-context": ("lossy-bounded-f32-longfit-context.vpk", VOLUME_PATHS),
    # and by static rANS tables in those contexts (type 4)
    "lossy-longfit-static": ("lossy-bounded-f32-longfit-static.vpk", VOLUME_PATHS),
    # container format version 2 (formats/vpk-2.md): varint records, dictionary-coded
    # header and summary; one brick, and eight
    "compact": ("vpk2-lossy-bounded-f32.vpk", VOLUME_PATHS),
    "compact-bricks": ("vpk2-wavelet-53-arith-u8.vpk", VOLUME_PATHS),
    # 64-bit label ids, a (z, y, x, c) volume stored as its channels, and a 4-D series
    # with its time steps interleaved (header "layout")
    "lossless-u64": ("lossless-labels-u64.vpk", VOLUME_PATHS),
    "channels": ("lossless-channels-rgb-u8.vpk", ("decompress", "info", "stdin")),
    "interleaved": ("lossless-interleaved-u8.vpk", ("decompress", "info", "play", "stdin")),
    "animation": (
        "animation-ibbp-bounded-u8.vpk",
        ("decompress", "frame", "info", "play", "stdin"),
    ),
    "octree": ("octree-bounded-u8.vpk", ("decompress", "level", "error", "info", "walk", "render")),
    "mesh": ("mesh-1-grid.vpk", ("decompress", "info", "render", "stdin")),
}
MODES = ("raw", "payload", "header")
DECODES = ("decompress", "roi", "frame", "level", "error", "stdin")  # paths whose output is data
FAILURES = ("internal", "signal", "timeout", "usage", "other")
COMPILING = "compiling kernels"  # the CLI's notice while numba compiles (cli/notices.py)
OUTCOMES = ("error", "same", "silent", *FAILURES)
# values a header field is replaced by: other types, extremes, the empty and the absurd
NASTY = [None, {}, [], "", "x", True, False, 0, -1, 1, 2, 3, 255, 65536, 2**31, 2**32 + 1,
         2**63, -(2**63), 2**64, 10**30, 0.5, -0.5, 1e-308, 1e308, -1e308, 1.7e308, 1e200,
         [0], [1, 2], [1, 2, 3], [2**31, 2**31, 2**31], [1e308, 1e308, 1e308], [None] * 3,
         ["a", "b", "c"], {"id": "zstd"}, {"id": None}, [[1]], "uint8", "float64", "<f8", "|b1",
         "V8", "O"]  # fmt: skip


def make_lossy_nan(path: pathlib.Path) -> None:
    """A float32 volume with NaN and Inf voxels, coded within an error bound."""
    import numpy as np

    from volpack import api

    z, y, x = np.mgrid[:20, :18, :22].astype(np.float32)
    a = np.sin(z / 3) * np.cos(y / 4) + x / 22
    a[3, 4, 5] = np.nan
    a[10, :, 7] = np.nan
    a[15, 2, 2] = np.inf
    api.compress(a.astype(np.float32), str(path), max_error=0.01, brick=16, force=True)


def argv_for(kind: str, path: str, src: str, out: pathlib.Path) -> tuple[list[str], str | None]:
    """The command line of one decode path, and the file it reads on standard input."""
    dec = str(out / ("o.vtu" if kind == "mesh" else "o.npy"))
    if path == "decompress":
        return ["decompress", src, dec, "--force"], None
    if path == "stdin":
        return ["decompress", "-", dec, "--force"], src
    if path == "roi":
        return ["decompress", src, dec, "--force", "--roi", "2:9,0:7,3:12"], None
    if path == "frame":
        return ["decompress", src, dec, "--force", "--frame", "2"], None
    if path == "level":
        return ["decompress", src, dec, "--force", "--level", "1"], None
    if path == "error":
        return ["decompress", src, dec, "--force", "--error", "6"], None
    if path == "info":
        return ["info", src, "--json"], None
    if path == "render":  # a small image: the decode is what is tested (no --budget: a
        # mutant that is no octree any more would make it a usage error)
        return ["render", src, str(out / "o.png"), "--force", "--size", "16x16"], None
    if path == "play":
        return ["play", src, "--size", "12x12"], None
    if path == "walk":
        return ["walk", src, "--orbit", "2", "--budget", "16", "--size", "12x12"], None
    raise ValueError(path)


# -- mutations ------------------------------------------------------------------------


def parse(blob: bytes):
    from volpack.format.container import Reader

    with Reader(blob) as r:
        return dict(r.header), r.summary, [(t, n, r.read(t, n)) for t, n in r.keys()], r.entries


def rebuild(header, summary, chunks, errors) -> bytes:
    from volpack.format.container import Writer

    buf = io.BytesIO()
    w = Writer(buf, header)
    for (t, n, p), e in zip(chunks, errors):
        w.write(t, n, p, e)
    w.close(summary)
    return buf.getvalue()


def mutate_bytes(rng: random.Random, b: bytes, ops: int) -> bytes:
    x = bytearray(b)
    for _ in range(ops):
        if not x:
            x.append(rng.randrange(256))
            continue
        op = rng.random()
        i = rng.randrange(len(x))
        if op < 0.35:
            x[i] ^= 1 << rng.randrange(8)
        elif op < 0.55:
            x[i] = rng.choice((0, 0xFF, 0x7F, 0x80, rng.randrange(256)))
        elif op < 0.65:
            del x[i : i + rng.randint(1, 16)]
        elif op < 0.75:
            x[i:i] = bytes(rng.randrange(256) for _ in range(rng.randint(1, 16)))
        elif op < 0.85:
            del x[rng.randrange(len(x) + 1) :]
        elif op < 0.95:
            n = rng.randint(1, 8)
            x[i : i + n] = bytes(n)
        else:
            j = rng.randrange(len(x))
            n = rng.randint(1, 32)
            x[i : i + n] = x[j : j + n]
    return bytes(x)


def _paths(obj, prefix=()):
    yield prefix
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _paths(v, (*prefix, k))
    elif isinstance(obj, list) and len(obj) <= 64:
        for i, v in enumerate(obj):
            yield from _paths(v, (*prefix, i))


def mutate_field(rng: random.Random, doc: dict) -> dict:
    doc = copy.deepcopy(doc)
    paths = [p for p in _paths(doc) if p]
    if not paths:
        return {"x": rng.choice(NASTY)}
    p = rng.choice(paths)
    parent = doc
    for k in p[:-1]:
        parent = parent[k]
    old = parent[p[-1]]
    r = rng.random()
    if r < 0.12 and isinstance(parent, dict):
        del parent[p[-1]]
    elif r < 0.4 and isinstance(old, (int, float)) and not isinstance(old, bool):
        parent[p[-1]] = rng.choice(
            (old * 2 ** rng.randint(8, 40), -old, old + 1, old - 1, old * 1e300, old / 1e300, 0)
        )
    else:
        parent[p[-1]] = copy.deepcopy(rng.choice(NASTY))
    return doc


def mutant(rng: random.Random, mode: str, seed: bytes, parsed) -> bytes:
    if mode == "raw":
        return mutate_bytes(rng, seed, rng.choice((1, 1, 1, 2, 3, 8)))
    header, summary, chunks, entries = parsed
    errors = [e.error for e in entries]
    if mode == "payload":
        chunks = list(chunks)
        i = rng.randrange(len(chunks))
        t, n, p = chunks[i]
        chunks[i] = (t, n, mutate_bytes(rng, p, rng.choice((1, 1, 2, 4))))
        return rebuild(header, summary, chunks, errors)
    if rng.random() < 0.85:
        header = mutate_field(rng, header)
    else:
        summary = mutate_field(rng, summary or {})
    try:
        return rebuild(header, summary, chunks, errors)
    except Exception:  # a value JSON cannot hold: keep the file as it was
        return seed


# -- running --------------------------------------------------------------------------


def run_child(argv, stdin_path, out: pathlib.Path, seconds: float, mem: int):
    """Fork, run the CLI with limits, return (outcome-ish, exit/signal, stderr, digest)."""
    for f in out.iterdir():
        if f.is_file():
            f.unlink()
    pid = os.fork()
    if pid == 0:  # the child: never returns
        gc.disable()  # short-lived: a collection would touch (copy) the parent's pages
        code = 5
        try:
            resource.setrlimit(resource.RLIMIT_AS, (mem, mem))
            signal.alarm(max(1, int(seconds)))
            fin = os.open(stdin_path or os.devnull, os.O_RDONLY)
            fo = os.open(out / "stdout", os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            fe = os.open(out / "stderr", os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            os.dup2(fin, 0)
            os.dup2(fo, 1)
            os.dup2(fe, 2)
            sys.stdin = open(0, closefd=False)  # multiprocessing set it to os.devnull
            from volpack.cli import main

            try:
                main(argv, prog_name="volpack", standalone_mode=True)
                code = 0
            except SystemExit as e:
                code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
        except BaseException:
            import traceback

            traceback.print_exc()
            code = 6
        finally:
            try:
                sys.stdout.flush()
                sys.stderr.flush()
            finally:
                os._exit(code)
    _, status = os.waitpid(pid, 0)
    err = (out / "stderr").read_text(errors="replace")
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        return ("timeout" if sig == signal.SIGALRM else "signal"), sig, err, None
    code = os.WEXITSTATUS(status)
    if code == 0:
        h = hashlib.sha256()
        for name in sorted(os.listdir(out)):
            if name not in ("stderr",):
                h.update(name.encode() + (out / name).read_bytes())
        return "ok", 0, err, h.hexdigest()
    lines = [ln for ln in err.splitlines() if ln.strip()]
    if code == 1 and lines and lines[-1].startswith("volpack: error: "):
        return "error", 1, err, None
    kind = {2: "usage", 3: "internal"}.get(code, "other")
    return kind, code, err, None


def warm_up(seeds: dict, work: pathlib.Path) -> None:
    """Run each path once in this process, so that the workers and their children
    (forked from it) inherit compiled kernels: compiled once, not per worker or run."""
    from volpack.cli import main

    run_dir = work / "warm"
    run_dir.mkdir(parents=True, exist_ok=True)
    for kind, (_, paths) in KINDS.items():
        src = work / f"{kind}.vpk"
        src.write_bytes(seeds[kind])
        for path in paths:
            argv, sin = argv_for(kind, path, str(src), run_dir)
            if sin is None:
                with (
                    contextlib.redirect_stdout(io.StringIO()),
                    contextlib.redirect_stderr(io.StringIO()),
                ):
                    try:
                        main(argv, prog_name="volpack", standalone_mode=False)
                    except BaseException:
                        pass


def worker(wid: int, nworkers: int, args, seeds: dict, scratch: pathlib.Path, q) -> None:
    """Run mutants wid, wid + nworkers, ... and send per-mutant rows to the parent."""
    work = scratch / f"w{wid}"
    run_dir = work / "run"
    run_dir.mkdir(parents=True, exist_ok=True)
    parsed = {k: parse(b) for k, b in seeds.items()}
    gc.collect()
    gc.freeze()  # the objects so far are never scanned again, so children leave them shared
    ref = {}
    for kind, (_, paths) in KINDS.items():
        src = work / f"{kind}.vpk"
        src.write_bytes(seeds[kind])
        for path in paths:
            argv, sin = argv_for(kind, path, str(src), run_dir)
            outcome, code, err, digest = run_child(argv, sin, run_dir, args.time_limit, args.mem)
            ref[kind, path] = digest if outcome == "ok" else None
            if outcome != "ok":
                q.put(("reference", kind, path, outcome, err[-400:]))
    # --seconds counts this worker's mutants only, not compiling or the reference runs
    deadline = time.time() + (args.seconds if args.seconds else 1e12)
    kinds = list(KINDS)
    mpath = work / "m.vpk"
    i = wid
    while i < args.count and time.time() < deadline:
        rng = random.Random(f"{args.seed}:{i}")
        kind = kinds[i % len(kinds)]
        paths = KINDS[kind][1]
        path = paths[(i // len(kinds)) % len(paths)]
        mode = rng.choice(MODES)
        blob = mutant(rng, mode, seeds[kind], parsed[kind])
        if blob == seeds[kind]:
            q.put(("row", i, kind, path, mode, "unchanged", 0.0))
            i += nworkers
            continue
        mpath.write_bytes(blob)
        argv, sin = argv_for(kind, path, str(mpath), run_dir)
        t0 = time.perf_counter()
        outcome, code, err, digest = run_child(argv, sin, run_dir, args.time_limit, args.mem)
        dt = time.perf_counter() - t0
        if outcome == "timeout" and COMPILING in err:
            # a mutant's header named a type no kernel was compiled for: a first-use
            # compile, not a hang. Run it again with room to compile (the kernel is then
            # cached for later runs); that run's outcome counts, its time is left out.
            q.put(("compiled", i, kind, path, mode))
            outcome, code, err, digest = run_child(argv, sin, run_dir, args.compile_limit, args.mem)
            dt = -1.0
        if outcome == "ok":
            outcome = "same" if digest == ref.get((kind, path)) else "silent"
        if outcome in FAILURES:
            keep = pathlib.Path(args.out) / "failures"
            keep.mkdir(parents=True, exist_ok=True)
            stem = f"{kind}-{path}-{mode}-{outcome}-{i}"
            (keep / f"{stem}.vpk").write_bytes(blob)
            debug = run_child(["--debug", *argv], sin, run_dir, args.time_limit, args.mem)[2]
            (keep / f"{stem}.txt").write_text(
                f"volpack {' '.join(argv)}{' < file' if sin else ''}\nstatus {code}\n\n{err}\n"
                f"with --debug:\n{debug}"
            )
        q.put(("row", i, kind, path, mode, outcome, dt))
        i += nworkers
    q.put(("done", wid))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--count", type=int, default=2000, help="mutants (upper bound)")
    ap.add_argument(
        "--seconds", type=float, default=None,
        help="stop each worker after this long running mutants (compiling not counted)",
    )  # fmt: skip
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--time-limit", type=float, default=10.0, help="seconds per run")
    ap.add_argument(
        "--compile-limit", type=float, default=300.0,
        help="seconds for the rerun of a run that was still compiling at --time-limit",
    )  # fmt: skip
    ap.add_argument(
        "--kinds", default=None,
        help=f"comma-separated stream kinds to fuzz (default: all of {', '.join(KINDS)})",
    )  # fmt: skip
    ap.add_argument("--mem", type=float, default=4.0, help="GB of address space per run")
    ap.add_argument("--out", default=str(ROOT / "results" / "fuzz"))
    ap.add_argument(
        "--scratch",
        default=None,
        help="folder for the runs' files (default: a folder in /dev/shm when there is one, "
        "where the outputs' fsync costs nothing; else OUT/work)",
    )
    ap.add_argument(
        "--table", metavar="CSV", default=None,
        help="only print the per-kind table of a summary.csv (as in the README) and exit",
    )  # fmt: skip
    args = ap.parse_args()
    if args.table:
        with open(args.table, newline="") as f:
            print(kind_table(list(csv.DictReader(f))))
        return 0
    if args.kinds:
        chosen = args.kinds.split(",")
        unknown = sorted(set(chosen) - set(KINDS))
        if unknown:
            ap.error(f"expected kinds among {', '.join(KINDS)}, found {', '.join(unknown)}")
        for kind in list(KINDS):  # before the workers fork, so they see the same table
            if kind not in chosen:
                del KINDS[kind]
    args.mem = int(args.mem * (1 << 30))
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.time()

    import multiprocessing as mp
    import tempfile

    ctx = mp.get_context("fork")
    if args.scratch:
        scratch = pathlib.Path(args.scratch)
    elif os.access("/dev/shm", os.W_OK):
        scratch = pathlib.Path(tempfile.mkdtemp(prefix="volpack-fuzz-", dir="/dev/shm"))
    else:
        scratch = out / "work"
    scratch.mkdir(parents=True, exist_ok=True)
    seeds = {}
    nan_path = out / "lossy-nan-seed.vpk"
    make_lossy_nan(nan_path)
    for kind, (name, _) in KINDS.items():
        seeds[kind] = (EXAMPLES / name).read_bytes() if name else nan_path.read_bytes()
    warm_up(seeds, scratch)
    q = ctx.Queue()
    procs = [
        ctx.Process(target=worker, args=(w, args.workers, args, seeds, scratch, q))
        for w in range(args.workers)
    ]
    for p in procs:
        p.start()
    rows, done, refs, compiled = [], 0, [], []
    while done < len(procs):
        msg = q.get()
        if msg[0] == "done":
            done += 1
        elif msg[0] == "reference":
            refs.append(msg[1:])
        elif msg[0] == "compiled":
            compiled.append(msg[1:])
        else:
            rows.append(msg[1:])
    for p in procs:
        p.join()
    if not args.scratch:
        shutil.rmtree(scratch, ignore_errors=True)
    elapsed = time.time() - t0
    return report(rows, refs, compiled, out, elapsed, args)


def kind_table(summary: list[dict]) -> str:
    """Outcomes per kind (all mutations) from the rows of ``summary.csv``."""
    lines = [
        "| kind | mutants | clean error | same output | different output | failures |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for kind in KINDS:
        c = {
            k: sum(int(r[k]) for r in summary if r["kind"] == kind) for k in ("mutants", *OUTCOMES)
        }
        fails = sum(c[f] for f in FAILURES)
        lines.append(
            f"| {kind} | {c['mutants']:,} | {c['error']:,} | {c['same']:,} | {c['silent']:,} "
            f"| {fails} |"
        )
    return "\n".join(lines)


def report(rows, refs, compiled, out: pathlib.Path, elapsed: float, args) -> int:
    counts: dict = {}
    for _, kind, _path, mode, outcome, _dt in rows:
        counts.setdefault((kind, mode), dict.fromkeys((*OUTCOMES, "unchanged"), 0))[outcome] += 1
    with open(out / "summary.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["kind", "mutation", "mutants", *OUTCOMES])
        for (kind, mode), c in sorted(counts.items()):
            w.writerow([kind, mode, sum(c[o] for o in OUTCOMES), *(c[o] for o in OUTCOMES)])
    with open(out / "summary.csv", newline="") as f:
        per_kind = kind_table(list(csv.DictReader(f)))
    run = [r for r in rows if r[4] != "unchanged"]
    print(f"{len(run)} mutants ({len(rows) - len(run)} unchanged skipped) in {elapsed:.0f} s, "
          f"seed {args.seed}, {args.workers} workers, limits {args.time_limit:g} s and "
          f"{args.mem / 2**30:g} GB")  # fmt: skip
    print()
    print("| kind | mutation | mutants | " + " | ".join(OUTCOMES) + " |")
    print("|---|---|---:|" + "---:|" * len(OUTCOMES))
    for (kind, mode), c in sorted(counts.items()):
        n = sum(c[o] for o in OUTCOMES)
        print(f"| {kind} | {mode} | {n} | " + " | ".join(str(c[o]) for o in OUTCOMES) + " |")
    print()
    print(per_kind)
    print()
    print("silently accepted (payload mutants, data decode paths: decoded to different output):")
    for kind in KINDS:
        sel = [r for r in run if r[1] == kind and r[3] == "payload" and r[2] in DECODES]
        bad = sum(r[4] == "silent" for r in sel)
        if sel:
            print(f"  {kind}: {bad}/{len(sel)} = {100 * bad / len(sel):.1f} %")
    timed = [r for r in run if r[5] >= 0]
    times = sorted(r[5] for r in timed) or [0.0]
    slow = max(timed, key=lambda r: r[5], default=None)
    print(
        f"run time: median {times[len(times) // 2]:.3f} s, slowest {times[-1]:.2f} s"
        + (f" ({slow[1]} {slow[2]} {slow[3]}, mutant {slow[0]})" if slow else "")
    )
    if compiled:
        print(
            f"{len(compiled)} runs were still compiling a kernel at {args.time_limit:g} s "
            f"and ran again with {args.compile_limit:g} s (outcome above, time left out): "
            + ", ".join(f"{k} {p} {m} {i}" for i, k, p, m in compiled[:20])
        )
    by_path: dict = {}
    for r in timed:
        by_path.setdefault((r[1], r[2]), []).append(r[5])
    print(
        "median run time per path: "
        + ", ".join(
            f"{k} {p} {sorted(v)[len(v) // 2]:.3f} s" for (k, p), v in sorted(by_path.items())
        )
    )
    for kind, path, outcome, err in refs:
        print(f"reference run failed: {kind} {path}: {outcome}: {err}")
    fails = sum(r[4] in FAILURES for r in run)
    print(f"failures: {fails}" + (f" (kept in {out / 'failures'})" if fails else ""))
    return 1 if fails or refs else 0


if __name__ == "__main__":
    sys.exit(main())
