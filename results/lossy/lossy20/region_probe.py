"""Whether type 4's static tables lose to type 3's adaptive models by the field's changes
over the brick (climate fields vary with latitude): static estimates (tables counted,
as static_probe.py) of the magnitude tokens in the activity classes alone, and with the
classes split by the half of the brick along each axis, or by the sign context (whether
the neighbours' signs disagree: a bit of type 3's zero-flag context; or all of it);
type 3's coded bytes beside.

    python results/lossy/lossy20/region_probe.py climate_t:1e-3,cam_t:1e-3
"""
import sys

import numpy as np
from common import residuals
from static_probe import contexts, cost, tokens

from volpack.volume_codec import bounded_longfit as lf

for name, rel, a, codec, q, (r, plan, w) in residuals(sys.argv[1]):
    flat = r.reshape(-1)
    act, sg = contexts(flat, *r.shape)
    tok, raw = tokens(np.abs(flat), zigzag=False)  # type 4's magnitude tokens
    t3 = len(lf.code_residuals(r))
    out = [f"{name} {rel} {r.shape}: type3 {t3}"]
    idx = np.indices(r.shape).reshape(3, -1)
    for label, c, n in [("act", act, 48)] + [
        (f"act x half of axis {ax}", act * 2 + (idx[ax] >= r.shape[ax] // 2), 96) for ax in range(3)
    ] + [("act x signs disagree (type 3's zero-flag bit)", act * 2 + ((sg + 1) >> 1 & 1), 96),
         ("act x sign context", act * 4 + sg, 192)]:
        b, tab, top = cost(tok, c, raw, n)
        out.append(f"  {label}: {b:.0f} B (tables {tab}, {top} ctx), signs not counted")
    print("\n".join(out), flush=True)
