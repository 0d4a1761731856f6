"""pfd32's corpus: each item's default-effort .vpk (made once, by whatever volpack is
imported) and the predictfit streams its decode passes to ``predictfit.decode``, cached
under $PFD32_DATA (default /tmp/pfd32/data) as ``<item>.vpk`` and ``<item>.pkl``.

An item is a lossless volume (``ct_head``) or a lossy cell (``lossy:sst_monthly@1e-3``:
the field at that bound relative to its value range).

    PYTHONPATH=/tmp/pfd32/base python results/lossless/pfd32/capture.py ct_head ...
"""

import os
import pickle
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
DATA = Path(os.environ.get("PFD32_DATA", "/tmp/pfd32/data"))


def corpus() -> dict[str, list[str]]:
    sets = {}
    for line in (Path(__file__).parent / "corpus.txt").read_text().splitlines():
        if line and not line.startswith("#"):
            k, v = line.split(":", 1)
            sets[k.strip()] = v.split()
    return sets


def array(item: str) -> tuple[np.ndarray, float | None]:
    """The item's array and its absolute bound (None: lossless)."""
    from datasets import load

    if item.startswith("lossy:"):
        name, rel = item[6:].split("@")
        a = np.ascontiguousarray(load(name)[0])
        return a, float(rel) * (float(a.max()) - float(a.min()))
    return np.ascontiguousarray(load(item)[0]), None


def blob(item: str) -> bytes:
    p = DATA / f"{item.replace(':', '_')}.vpk"
    if not p.exists():
        from volpack import api

        a, e = array(item)
        DATA.mkdir(parents=True, exist_ok=True)
        p.write_bytes(bytes(api.compress_array(a) if e is None else api.compress_array(a, max_error=e)))
    return p.read_bytes()


def streams(item: str) -> list[tuple]:
    """``predictfit.decode``'s arguments for every predictfit stream of the item's decode."""
    p = DATA / f"{item.replace(':', '_')}.pkl"
    if p.exists():
        return pickle.loads(p.read_bytes())
    from volpack import api
    from volpack.volume_codec import predictfit as pf

    got = []
    real = pf.decode

    def keep(data, shape, lo, hi, mask=None, fill=0, low=False, tex=False, mix=False, local=False, plane=False):
        m = None if mask is None else np.array(mask, copy=True)
        got.append((bytes(data), tuple(int(s) for s in shape), int(lo), int(hi), m, int(fill),
                    bool(low), bool(tex), bool(mix), bool(local), bool(plane)))
        return real(data, shape, lo, hi, mask, fill, low, tex, mix, local, plane)

    pf.decode = keep
    try:
        api.decompress_array(blob(item), workers=1)
    finally:
        pf.decode = real
    p.write_bytes(pickle.dumps(got))
    return got


if __name__ == "__main__":
    items = sys.argv[1:] or [i for v in corpus().values() for i in v]
    for it in items:
        s = streams(it)
        n = sum(int(np.prod(x[1])) for x in s)
        flags = sorted({x[6:11] for x in s})
        print(it, len(blob(it)), "streams", len(s), "voxels", n, "flags(low,tex,mix,local,plane)", flags, flush=True)
