"""Per-part CPU of the first frame's chunk decodes, one thread: fused kernel, decoder alone, lifting alone."""
import contextlib, io, sys, tempfile, time, pickle
import numpy as np
from volpack.cli import main as cli
from volpack.octree import chunk
from volpack.entropy import arith
from volpack.wavelet.dwt3 import dwt3_kernel

calls = []
orig = chunk.decode_chunk
def rec(data, scan, nmax, scale, norm, bounds, low, c, levels, spec):
    calls.append((data.copy(), scan, nmax, scale, norm, bounds, low.copy(), c.shape, c.dtype, levels, spec))
    return orig(data, scan, nmax, scale, norm, bounds, low, c, levels, spec)
chunk.decode_chunk = rec
with contextlib.redirect_stdout(io.StringIO()):
    cli(["walk", sys.argv[1], tempfile.mkdtemp() + "/", "--orbit", "1", "-j", "1"], standalone_mode=False)
chunk.decode_chunk = orig
calls = [c for c in calls if c[7] == (32, 32, 32)][-198:]
print(len(calls), "chunks; bytes", sum(c[0].size for c in calls))
def run(part):
    t = time.thread_time()
    for data, scan, nmax, scale, norm, bounds, low, shape, dt, levels, spec in calls:
        if part == "fused":
            c = np.empty(shape, dt)
            orig(data, scan, nmax, scale, norm, bounds, low, c, levels, spec)
        elif part == "tabled":
            flat = np.zeros(np.prod(shape), np.int64)
            if data.size:
                arith.decode_tabled_kernel(data, scan[0].perm, scan[1], scan[0].cls, flat, nmax)
        elif part == "arith":
            flat = np.zeros(np.prod(shape), np.int64)
            sc = scan[0] if isinstance(scan, tuple) and len(scan) == 2 else scan
            if data.size:
                arith.decode_kernel(data, sc.perm, sc.end, sc.parent, sc.cls, sc.nbr, flat, nmax)
        elif part == "dwt":
            c = np.zeros(shape, dt)
            tmp = np.empty(c.size // 2 + 1, dt)
            dwt3_kernel(c, tmp, *levels, spec, True)
    return time.thread_time() - t
parts = ["fused", "arith", "dwt"] + (["tabled"] if hasattr(arith, "decode_tabled_kernel") else [])
res = {p: [] for p in parts}
for p in parts:
    run(p)
for _ in range(int(sys.argv[2]) if len(sys.argv) > 2 else 5):
    for p in parts:
        res[p].append(run(p))
for p in parts:
    ts = sorted(res[p])
    print(f"{p}: least {1e3*ts[0]:.1f} ms, median {1e3*ts[len(ts)//2]:.1f} ms (CPU, {len(calls)} chunks of 32^3, one thread)")
