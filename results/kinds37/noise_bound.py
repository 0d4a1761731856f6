"""Shannon bounds of the volumes whose noise make.py adds as white Gaussian noise.

    PYTHONPATH=. python results/kinds37/noise_bound.py DIR [trial_base.jsonl]

For aneurism_u8 (sigma 3 on uint8) and chameleon_u16 (sigma 12 counts on uint16) the
noise-free field t is rebuilt by running make.py's maker with its full-size normal
draw replaced by zeros (and rounded as the maker rounds); each voxel's stored value is round(t + N(0, s)) clipped to the
dtype, so its entropy given t is exact, and the sum over voxels is a lower bound on any
coder that does not know the noise's seed (it even knows t for free). Prints the bound in
bytes, volpack's and the best peer's payload over it.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
from scipy.special import ndtr

sys.path.insert(0, str(Path(__file__).resolve().parent))
import make  # noqa: E402


class _Quiet:
    """An rng that draws as the real one but gives zeros for the full-size normal draw."""

    def __init__(self, rng, shape):
        self.rng, self.shape = rng, tuple(shape)

    def normal(self, *a, **k):
        v = self.rng.normal(*a, **k)
        return np.zeros_like(v) if np.shape(v) == self.shape else v

    def __getattr__(self, name):
        return getattr(self.rng, name)


def entropy_bits(t: np.ndarray, s: float, top: int) -> float:
    """Sum over voxels of H(clip(round(t + N(0, s)), 0, top)) in bits."""
    t = t.ravel()
    k = np.arange(-int(7 * s) - 2, int(7 * s) + 3)
    total = 0.0
    for i in range(0, t.size, 1 << 16):
        c = t[i : i + (1 << 16), None]
        base = np.floor(c)
        v = base + k[None]  # candidate stored values
        p = ndtr((v + 0.5 - c) / s) - ndtr((v - 0.5 - c) / s)
        # clipping: the mass below 0 and above top piles onto the ends
        lo = ndtr((-0.5 - c) / s)[:, 0]
        hi = 1 - ndtr((top + 0.5 - c) / s)[:, 0]
        p = np.where((v < 0) | (v > top), 0.0, p)
        p[v == 0] += np.broadcast_to(lo[:, None], p.shape)[v == 0]
        p[v == top] += np.broadcast_to(hi[:, None], p.shape)[v == top]
        with np.errstate(divide="ignore", invalid="ignore"):
            total += float(-np.nansum(np.where(p > 0, p * np.log2(p), 0.0)))
    return total


def main() -> None:
    d = Path(sys.argv[1])
    runs = {}
    if len(sys.argv) > 2:
        for line in open(sys.argv[2]):
            c = json.loads(line)
            if c["json"]:
                runs[c["name"]] = c["json"]
    names = list(make.MAKERS)
    for name, s, top in (("aneurism_u8", 3.0, 255), ("chameleon_u16", 12.0, 65535)):
        stored = np.load(d / f"{name}.npy")
        rng = np.random.default_rng(3700 + names.index(name))
        # the maker with its noise zeroed: t rounded to integers (chameleon's t is whole
        # anyway; with s >= 3 the entropy of a rounded Gaussian barely depends on where
        # t falls between two integers: the bound moves by far less than 0.1 %)
        t = make.MAKERS[name](_Quiet(rng, stored.shape)).astype(np.float64)
        bound = entropy_bits(t, s, top) / 8
        line = f"{name}: bound {bound:,.0f} B"
        if name in runs:
            j = runs[name]
            peers = [q for q in j["peers"] if q.get("lossless")]
            best = min(peers, key=lambda q: q["file_nbytes"])
            line += (f"; volpack {j['file_nbytes']:,} B = {j['file_nbytes'] / bound:.3f}x the bound, "
                     f"{best['name']} {best['file_nbytes']:,} B = {best['file_nbytes'] / bound:.3f}x; "
                     f"1.1x {best['name']} needs {best['file_nbytes'] / 1.1 / bound:.3f}x the bound")  # fmt: skip
        print(line, flush=True)


if __name__ == "__main__":
    main()
