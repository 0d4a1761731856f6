import sys, time
sys.path.insert(0, "scripts")
import numpy as np
import datasets
from volpack.volume_codec import bounded_interp as bi
from volpack.entropy import rans
from volpack.format.sections import take_section
from volpack.format.deflate import inflate
for name in sys.argv[1].split(","):
    a, _, _ = datasets.load(name); g = a.astype(np.float64)
    rng = float(g.max() - g.min())
    for rel in (1e-2, 1e-3):
        step = 2 * rel * rng
        T = ((1, bi.PERMS[:1]),)
        ing, rg = bi.encode(g, step, T, ("grouped",))
        inner = memoryview(ing)
        body, pos = take_section(inner, 4, "x")
        tables = inflate(body, 2 * (bi.N_SYM + 1) * bi.N_GROUP_CTX, "t")
        table, used = rans.unpack_tables(tables, bi.N_GROUP_CTX, bi.N_SYM, "x", bi.GROUP_BITS)
        raw, pos = take_section(inner, pos, "x")
        l0, pos = take_section(inner, pos, "x")
        d0 = np.frombuffer(l0 + bytes(2), dtype=np.uint8)
        d1 = np.frombuffer(bytes(inner[pos:]) + bytes(2), dtype=np.uint8)
        raw = np.frombuffer(bytes(raw) + bytes(8), dtype=np.uint8).copy()
        bins = np.zeros(g.size + 16, np.int32)
        rec = np.empty(g.shape); bn = np.zeros(g.size, np.int32)
        models = np.zeros(1, np.uint32)
        td, tw, tt = [], [], []
        for r in range(9):
            t = time.perf_counter(); st = bi._decode_groups(d0, d1, table, raw, bins); td.append(time.perf_counter() - t)
            assert st == 0
            t = time.perf_counter(); bi._decode_walk_given(rec.reshape(-1), bn, rec.shape, step, 1, bins, table, models); tw.append(time.perf_counter() - t)
            t = time.perf_counter(); bi.decode(ing, g.shape, step); tt.append(time.perf_counter() - t)
        ns = 1e9 / g.size
        print(f"{name} {rel:g} groups {min(td)*ns:.2f} walk {min(tw)*ns:.2f} whole {min(tt)*ns:.2f} ns/vox")
