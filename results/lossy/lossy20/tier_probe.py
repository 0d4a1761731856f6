"""Decoding speed of the long fit with its residual by static tables (type 4, step 23)
against what the encoder keeps without it, on one cell, in one process (CPU s, best of
7, interleaved): ``kept`` (today's encoder), ``without 4`` (type 4 never offered: main's
choice, type 3 where it is 2 % shorter than the middle tier), ``mid, without 4`` (the
middle tier's best without type 4: the codings type 4 competes with in its tier).

    python results/lossy/lossy20/tier_probe.py tgv_pressure:1e-5,tgv_vorticity:1e-3
"""
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "lossy19"))
from cells import cells  # noqa: E402

from volpack import api  # noqa: E402
from volpack.format.container import Reader  # noqa: E402
from volpack.format.sections import take_section  # noqa: E402
from volpack.volume_codec import bounded_longfit as lf  # noqa: E402
from volpack.volume_codec import lossy  # noqa: E402


def compress(a, e, static=True, slow=True):
    code, keep = lf.code_static, lossy.keep_faster
    if not static:
        lf.code_static = lambda r: None
    if not slow:
        lossy.keep_faster = lambda c: keep([x for x in c if x[0] < lossy.TIER_SLOW])
    try:
        return api.compress_array(a, max_error=e)
    finally:
        lf.code_static, lossy.keep_faster = code, keep


def kinds(blob):
    out = []
    with Reader(blob) as r:
        for _, _, p in r:
            k = str(p[0])
            if p[0] & 8 and not p[0] & (4 | 16 | 64 | 128):
                k += f"/type {take_section(memoryview(p), 1, 'inner')[0][4]}"
            out.append(k)
    return out


for name, rel, a, e in cells(sys.argv[1]):
    blobs = {"kept": compress(a, e), "without 4": compress(a, e, static=False),
             "mid, without 4": compress(a, e, static=False, slow=False)}  # fmt: skip
    for b in blobs.values():
        assert np.abs(api.decompress_array(b).astype(np.float64) - a).max() <= e
    times = {k: [] for k in blobs}
    for i in range(7):
        for k in (list(blobs) if i % 2 else list(blobs)[::-1]):
            t0 = time.process_time()
            api.decompress_array(blobs[k])
            times[k].append(time.process_time() - t0)
    mb = a.nbytes / 1e6
    t0 = min(times["kept"])
    print(f"{name} {rel}: " + "; ".join(
        f"{k} {len(b)} B {kinds(b)} {1e3 * min(times[k]):.1f} ms ({mb / min(times[k]):.0f} MB/s,"
        f" kept at {min(times[k]) / t0:.2f}x its speed)" for k, b in blobs.items()), flush=True)
