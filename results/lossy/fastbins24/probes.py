"""The fastbins24 probes: the interpolation path's bin codings on real fields at 1e-2
and 1e-3 of the range (cubic walk, stored order), ns a voxel, best of 9, one process.

    PYTHONPATH=. python results/lossy/fastbins24/probes.py codings cam_t,tgv_u,...
    PYTHONPATH=. python results/lossy/fastbins24/probes.py kernels cam_t,tgv_u,...

``codings``: bytes and whole ``bounded_interp.decode`` time of each coding;
``kernels``: the grouped coding's bin pass and walk alone, and the whole decode.
"""

import sys
import time

sys.path.insert(0, "scripts")
import datasets  # noqa: E402
import numpy as np  # noqa: E402

from volpack.entropy import rans  # noqa: E402
from volpack.format.deflate import inflate  # noqa: E402
from volpack.format.sections import take_section  # noqa: E402
from volpack.volume_codec import bounded_interp as bi  # noqa: E402

CUBIC = ((1, bi.PERMS[:1]),)


def best(f, n=9):
    ts = []
    for _ in range(n):
        t = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t)
    return min(ts)


def codings(g, step, name, rel):
    ins, rs = bi.encode(g, step, CUBIC, ("static",))
    ing, rg = bi.encode(g, step, CUBIC, ("grouped",))
    ina, _ = bi.encode(g, step, CUBIC, ("adaptive",))
    assert np.array_equal(rs, rg) and np.array_equal(bi.decode(ing, g.shape, step), rg)
    ns = 1e9 / g.size
    t = [best(lambda i=i: bi.decode(i, g.shape, step)) * ns for i in (ins, ing, ina)]
    print(f"{name} {rel:g} bytes static {len(ins)} grouped {len(ing)} ({len(ing)/len(ins):.3f}) "
          f"adaptive {len(ina)} ({len(ina)/len(ing):.3f}) | ns/vox static {t[0]:.1f} "
          f"grouped {t[1]:.1f} adaptive {t[2]:.1f}")  # fmt: skip


def kernels(g, step, name, rel):
    ing, _ = bi.encode(g, step, CUBIC, ("grouped",))
    inner = memoryview(ing)
    body, pos = take_section(inner, 4, "x")
    tables = inflate(body, 2 * (bi.N_SYM + 1) * bi.N_GROUP_CTX, "t")
    table, _ = rans.unpack_tables(tables, bi.N_GROUP_CTX, bi.N_SYM, "x", bi.GROUP_BITS)
    raw, pos = take_section(inner, pos, "x")
    l0, pos = take_section(inner, pos, "x")
    d0 = np.frombuffer(l0 + bytes(2), dtype=np.uint8)
    d1 = np.frombuffer(bytes(inner[pos:]) + bytes(2), dtype=np.uint8)
    raw = np.frombuffer(bytes(raw) + bytes(8), dtype=np.uint8).copy()
    bins = np.zeros(g.size + bi.GROUP, np.int32)
    rec, bn, models = np.empty(g.shape), np.zeros(g.size, np.int32), np.zeros(1, np.uint32)
    flat = rec.reshape(-1)
    ns = 1e9 / g.size
    td = best(lambda: bi._decode_groups(d0, d1, table, raw, bins)) * ns
    tw = best(lambda: bi._decode_walk_given(flat, bn, g.shape, step, 1, bins, table, models)) * ns
    tt = best(lambda: bi.decode(ing, g.shape, step)) * ns
    print(f"{name} {rel:g} groups {td:.2f} walk {tw:.2f} whole {tt:.2f} ns/vox")


if __name__ == "__main__":
    probe = {"codings": codings, "kernels": kernels}[sys.argv[1]]
    for name in sys.argv[2].split(","):
        a, _, _ = datasets.load(name)
        g = a.astype(np.float64)
        for rel in (1e-2, 1e-3):
            probe(g, 2 * rel * float(g.max() - g.min()), name, rel)
