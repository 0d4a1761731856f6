"""Scratch (session 21, not kept): the blend's fitted predictor (16 neighbours, 4
gradient classes) replaced by a per-brick box fit's estimate (``box``) or averaged with
it (``avg``), in the real ``effort="max"`` file: a copy of predictfit.py whose
``_fitted`` reads a precomputed array (written to a temporary folder and imported), the
local fit on top as in version 9. ``same`` hands it the 16-neighbour estimate itself and
must give version 9's bytes exactly (it does: the check of the copy). The box's weights
(2 bytes each) are counted in the file's header.

    PYTHONPATH=. python results/lossless/intbox21/scripts/box_q2.py mri_nibabel_t1 same:1x2x2:1 box:2x2x2:1
"""
import sys, re, json, time, types
import numpy as np
import os, tempfile
HERE = os.path.dirname(os.path.abspath(__file__))
TMP = tempfile.mkdtemp(prefix="intbox21_")
sys.path.insert(0, "scripts"); sys.path.insert(0, HERE); sys.path.insert(0, TMP)
import datasets
from volpack import api
from volpack.volume_codec import predictfit, lossless
import box_local as M

src = open("volpack/volume_codec/predictfit.py").read()
src = src.replace("from .._jit", "from volpack._jit").replace("from ..entropy", "from volpack.entropy")
src = src.replace("from ..errors", "from volpack.errors").replace("from . import localfit, residmix",
      "from volpack.volume_codec import localfit, residmix").replace("from .predict import", "from volpack.volume_codec.predict import")
src = src.replace("from .residmix import", "from volpack.volume_codec.residmix import")
src = re.sub(r'(def _fitted\(v, cf, c, i, sy, sz\):\n    """[^"]*"""\n)', r'\1    return cf[np.uint64(i)]\n', src)
src = src.replace('return th.astype("<u4").tobytes() + cf.astype("<i2").tobytes() + body',
                  'return bytes(EXTRA[0]) + body')
open(os.path.join(TMP, "scratch_pf.py"), "w").write(src + "\nEXTRA = [0]\n")
import scratch_pf as mod
ORIG_ENC = predictfit.encode

def make(box, classes, mode):
    def enc(values, lo, hi, classes_=4, mask=None, fitted=None, low=False, tex=False, mix=False, local=False):
        v = np.ascontiguousarray(values, np.int64) - lo
        b, nbytes = M.box_estimates(v, box, classes)
        cf, th = fitted if fitted is not None else predictfit.fit(v, mask)[0]
        # the 16-neighbour estimate where the box has none (needs a numpy replica: use kernel-free fallback)
        q16 = fitted16(v, cf, th)
        if mode == "same":
            q = q16; extra = 12 + 128
        elif mode == "box":
            q = np.where(b == M.NONE, q16, b)
            extra = nbytes + 12 + 128  # keep the 16 weights for the fallback region
        else:  # average of the two
            q = np.where(b == M.NONE, q16, (b + q16 + 1) >> 1)
            extra = nbytes + 12 + 128
        mod.EXTRA[0] = extra
        return mod.encode(values, lo, hi, classes_, mask, (q.reshape(-1), th), low, tex, mix, local)
    return enc

OFF = predictfit.FIT_OFFSETS
def fitted16(v, cf, th):
    nz, ny, nx = v.shape
    out = np.zeros(v.shape, np.int64)
    vv = v.astype(np.int64)
    z, y, x = np.meshgrid(np.arange(2, nz), np.arange(2, ny - 1), np.arange(2, nx - 1), indexing="ij")
    W, N, U = vv[z, y, x-1], vv[z, y-1, x], vv[z-1, y, x]
    NW, NE, UW, UN = vv[z, y-1, x-1], vv[z, y-1, x+1], vv[z-1, y, x-1], vv[z-1, y-1, x]
    g = abs(W-NW)+abs(N-NW)+abs(N-NE)+abs(U-UN)+abs(U-UW)
    c = (g > th[0]).astype(np.int64) + (g > th[1]) + (g > th[2])
    t = np.zeros(z.shape, np.int64)
    for k, (dz, dy, dx) in enumerate(OFF):
        t += cf[c * 16 + k] * vv[z-dz, y-dy, x-dx]
    out[z, y, x] = (t + (1 << 8)) >> 9
    return out

if __name__ == "__main__":
    names = sys.argv[1].split(",")
    for name in names:
        arr, _, _ = datasets.load(name)
        base = len(api.compress_array(arr, effort="max", workers=1))
        print(json.dumps(dict(volume=name, cand="v9", total=base, ratio=round(arr.nbytes / base, 4))), flush=True)
        for spec in sys.argv[2:]:
            mode, b, c = spec.split(":")
            box = tuple(int(t) for t in b.split("x"))
            predictfit.encode = make(box, int(c), mode)
            t = time.process_time()
            n = len(api.compress_array(arr, effort="max", workers=1))
            predictfit.encode = ORIG_ENC
            print(json.dumps(dict(volume=name, cand="q2" + mode, box=b, classes=int(c), total=n,
                  ratio=round(arr.nbytes / n, 4), saving_pct=round(100 * (base - n) / base, 3),
                  cpu_s=round(time.process_time() - t, 1))), flush=True)
