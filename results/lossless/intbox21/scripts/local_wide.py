"""Scratch (session 21, not kept): version 9's local fit (refitted along every row) over
more neighbours than the 16 of the blend's fitted predictor: a copy of localfit.py with
NF set to the count (written to a temporary folder), its estimates handed to the real
``effort="max"`` encoder in place of the local fit's.

    PYTHONPATH=. python results/lossless/intbox21/scripts/local_wide.py mri_dipy_s0,mri_nibabel_t1 4 6
    (the count of extra in-slice neighbours taken from EXTRA, in order)
"""
import json, os, sys, tempfile
import numpy as np
TMP = tempfile.mkdtemp(prefix="intbox21_lw_")
sys.path.insert(0, "scripts"); sys.path.insert(0, TMP)
import datasets
from volpack import api
from volpack.volume_codec import localfit, predictfit

# extra causal neighbours inside the local fit's reach (x <= nx - 2, y <= ny - 2)
EXTRA = ((0, 1, 2), (0, 2, 1), (0, 2, -1), (0, 2, 2), (1, 0, 2), (1, 2, 0), (1, 0, -2))
src = open("volpack/volume_codec/localfit.py").read().replace("from .._jit", "from volpack._jit")
ORIG = localfit.estimates

def scratch(n):
    name = f"lw{n}"
    open(os.path.join(TMP, name + ".py"), "w").write(src.replace("NF = 17 ", f"NF = {17 + n} "))
    return __import__(name)

if __name__ == "__main__":
    for vol in sys.argv[1].split(","):
        arr, _, _ = datasets.load(vol)
        base = len(api.compress_array(arr, effort="max", workers=1))
        print(json.dumps(dict(volume=vol, cand="v9", total=base, ratio=round(arr.nbytes / base, 4))), flush=True)
        for n in map(int, sys.argv[2:]):
            m = scratch(n)
            offs = tuple(predictfit.FIT_OFFSETS) + EXTRA[:n]
            localfit.estimates = lambda values, offsets, m=m, offs=offs: m.estimates(values, offs)
            t = len(api.compress_array(arr, effort="max", workers=1))
            localfit.estimates = ORIG
            print(json.dumps(dict(volume=vol, cand=f"local+{n}", total=t, ratio=round(arr.nbytes / t, 4),
                                  saving_pct=round(100 * (base - t) / base, 3))), flush=True)
