"""The quantised voxels the bounded encoder hands the long fit, per brick of a cell
(shared by this folder's probes)."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))

import datasets  # noqa: E402
from volpack import api  # noqa: E402
from volpack.volume_codec import lossy  # noqa: E402


def h(v) -> float:
    """Zeroth-order entropy of ``v``, bits in all."""
    import numpy as np

    _, n = np.unique(v, return_counts=True)
    return float(-(n * np.log2(n / v.size)).sum())


def cells(arg):
    """``name:rel,name:rel`` -> (name, rel, array, bound)."""
    for item in arg.split(","):
        name, rel = item.split(":")
        a = datasets.load(name)[0]
        yield name, rel, a, float(rel) * float(a.max() - a.min())


def quantised(a, e):
    """[(codec, q, best bytes so far)] of each brick the encoder would try the long fit on
    (the long fit itself left out)."""
    caught = []
    orig = lossy.BoundedCodec._longfit
    lossy.BoundedCodec._longfit = lambda self, q, best: caught.append((self, q.copy(), best))
    try:
        api.compress_array(a, max_error=e)
    finally:
        lossy.BoundedCodec._longfit = orig
    return caught
