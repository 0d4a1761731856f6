"""Scratch: is the residual's scale intensity-dependent once the activity is known?
Version 9's own `effort="max"` run (hyp.py's kernel copy, mode diag; its bytes checked
against the real encoder), the last encoder call's voxels: mean |residual| by quartile of
the prediction, overall and within terciles of the activity.
    PYTHONPATH=. python results/lossless/noisy23/scripts/diag.py NAMES"""
import sys
import numpy as np
sys.path.insert(0, "results/lossless/noisy23/scripts")
import hyp
sys.path.insert(0, "scripts")
import datasets
from volpack import api

for name in sys.argv[1].split(","):
    arr, _, _ = datasets.load(name)
    d, _ = hyp.size(arr, "diag")
    assert d == api.compress_array(arr, effort="max", workers=1)
    rec = hyp.LAST[0]
    act, pred, res = rec[:, 0], rec[:, 1], np.abs(rec[:, 2])
    qp = np.searchsorted(np.quantile(pred, [0.25, 0.5, 0.75]), pred, side="right")
    qa = np.searchsorted(np.quantile(act, [1 / 3, 2 / 3]), act, side="right")
    print(f"{name}: {rec.shape[0]} voxels, mean |r| {res.mean():.2f}")
    print("  prediction quartile:      " + "  ".join(f"{res[qp == k].mean():7.2f}" for k in range(4)))
    for a in range(3):
        s = qa == a
        print(f"  activity tercile {a}:       " + "  ".join(
            f"{res[s & (qp == k)].mean():7.2f}" if (s & (qp == k)).any() else "      -" for k in range(4)))
