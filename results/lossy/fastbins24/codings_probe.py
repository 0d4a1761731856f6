import sys, time
sys.path.insert(0, "scripts")
import numpy as np
import datasets
from volpack.volume_codec import bounded_interp as bi
for name in sys.argv[1].split(","):
    a, _, _ = datasets.load(name); g = a.astype(np.float64)
    rng = float(g.max() - g.min())
    for rel in (1e-2, 1e-3):
        step = 2 * rel * rng
        T = ((1, bi.PERMS[:1]),)
        ins, rs = bi.encode(g, step, T, ("static",))
        ing, rg = bi.encode(g, step, T, ("grouped",))
        ina, ra = bi.encode(g, step, T, ("adaptive",))
        assert np.array_equal(rs, rg)
        assert np.array_equal(bi.decode(ing, g.shape, step), rg), "roundtrip"
        ts, tg, ta = [], [], []
        for r in range(9):
            for inner, lst in ((ins, ts), (ing, tg), (ina, ta)):
                t = time.perf_counter(); bi.decode(inner, g.shape, step); lst.append(time.perf_counter() - t)
        ns = 1e9 / g.size
        print(f"{name} {rel:g} bytes static {len(ins)} grouped {len(ing)} ({len(ing)/len(ins):.3f}) adaptive {len(ina)} ({len(ina)/len(ing):.3f}) | ns/vox static {min(ts)*ns:.1f} grouped {min(tg)*ns:.1f} adaptive {min(ta)*ns:.1f}")
