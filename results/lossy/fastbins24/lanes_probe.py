import sys, time
sys.path.insert(0, "/work/wt/fastbins24/scripts")
import numpy as np, numba as nb
import datasets
from volpack.volume_codec import bounded_interp as bi
from volpack.entropy import rans

@nb.njit(boundscheck=False, nogil=True)
def dec1(data, table, raw, bins):
    xa, xb, pos = rans.open_states(data)
    n = bins.size - bi.GROUP
    bitpos = np.int64(0)
    prev = np.int64(0)
    for g in range(0, n, bi.GROUP):
        c, xa, pos = rans.decode_symbol_bits(data, xa, pos, prev, table, bi.GROUP_BITS)
        xa, xb = xb, xa
        if c >= bi.N_CLASS:
            return -1
        prev = c
        if c == 0:
            continue
        cc = bi.N_CLASS - 1 + c
        k = bi.PACK[c]
        if k == 1:
            for j in range(g, min(g + bi.GROUP, n)):
                u, xa, pos = rans.decode_symbol_bits(data, xa, pos, cc, table, bi.GROUP_BITS)
                xa, xb = xb, xa
                b, bitpos = bi._symbol_bin(u, raw, bitpos)
                bins[j] = b
            continue
        for j in range(g, min(g + bi.GROUP, n), k):
            v, xa, pos = rans.decode_symbol_bits(data, xa, pos, cc, table, bi.GROUP_BITS)
            xa, xb = xb, xa
            row = bi.UNPACKED[c, v & 63]
            for i in range(4):
                bins[j + i] = row[i]
    if not rans.state_ok(data, xa, xb, pos):
        return -1
    return 0

for name in sys.argv[1].split(","):
    a, _, _ = datasets.load(name); g = a.astype(np.float64)
    for rel in (1e-2, 1e-3):
        step = 2 * rel * float(g.max() - g.min())
        _, sym, ctx, raw, abin, adx = bi._run(g, step, (0, 1, 2), 1)
        n = sym.size
        toks = np.empty(n + n // 16 + 1, np.int64); cx = np.empty_like(toks)
        t = bi._group_tokens(sym, n, toks, cx); toks, cx = toks[:t], cx[:t]
        counts = np.bincount(cx * bi.N_SYM + toks, minlength=bi.N_GROUP_CTX * bi.N_SYM)
        freq = rans.normalise(counts.reshape(bi.N_GROUP_CTX, bi.N_SYM), bi.GROUP_BITS)
        table = rans.slot_table(freq, bi.GROUP_BITS)
        one = np.frombuffer(rans.encode(toks, cx, freq, bi.GROUP_BITS) + bytes(2), np.uint8)
        l0 = np.frombuffer(rans.encode(toks[0::2], cx[0::2], freq, bi.GROUP_BITS) + bytes(2), np.uint8)
        l1 = np.frombuffer(rans.encode(toks[1::2], cx[1::2], freq, bi.GROUP_BITS) + bytes(2), np.uint8)
        rawp = np.concatenate([raw, np.zeros(8, np.uint8)])
        b1 = np.zeros(n + 16, np.int32); b2 = np.zeros(n + 16, np.int32)
        assert dec1(one, table, rawp, b1) == 0 and bi._decode_groups(l0, l1, table, rawp, b2) == 0
        assert np.array_equal(b1, b2) and np.array_equal(b1[:n], abin)
        t1, t2 = [], []
        for r in range(15):
            s = time.perf_counter(); dec1(one, table, rawp, b1); t1.append(time.perf_counter() - s)
            s = time.perf_counter(); bi._decode_groups(l0, l1, table, rawp, b2); t2.append(time.perf_counter() - s)
        ns = 1e9 / n
        print(f"{name} {rel:g} one stream {min(t1)*ns:.2f} two lanes {min(t2)*ns:.2f} ns/voxel; bytes {one.size} vs {l0.size + l1.size + 4}")
