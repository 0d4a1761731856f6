"""The table of results/lossy/rough28: volpack against SZ3 and SPERR on the synthetic
Gaussian turbulence fields, and the most any coder that keeps every voxel within E can
reach on them (32 bits over the Shannon lower bound of bound.py).

python results/lossy/rough28/summarise.py  (reads json/F_E.json: `volpack -q compare
F.npy --rel-error E --peers --json`; turb's are the lead's, the same runs as results/unseen28/lossy/turb-*.json)
"""

import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))
from bound import ks_bits  # noqa: E402

FIELDS = {
    "turb": "k^-11/3, seed 28 (tuning)",
    "turb_s29_m113": "k^-11/3, seed 29 (held out)",
    "turb_s29_m3": "k^-3, seed 29 (held out)",
    "turb_s29_m133": "k^-13/3, seed 29 (held out)",
}


def main():
    print(
        "| field | E / range | volpack | SZ3 | SPERR | x best | at most (SLB) | at most x best "
        "| volpack / bound | decode MB/s volpack / SZ3 / SPERR |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    for f, what in FIELDS.items():
        path = HERE / f"{f}.npy"
        if not path.exists():
            continue
        x = np.load(path).astype(np.float64)
        var_x, _ = ks_bits(x)
        rng = x.max() - x.min()
        for e in ("1e-2", "1e-3", "1e-4", "1e-5"):
            j = HERE / "json" / f"{f}_{e}.json"
            if not j.exists():
                continue
            try:
                r = json.loads(j.read_text())
            except ValueError:  # (a run still writing it)
                continue
            p = {q["name"]: q for q in r["peers"]}
            best = max(p["sz3"]["ratio"], p["sperr"]["ratio"])
            step = 2 * float(e) * rng
            slb = 0.5 * np.log2(2 * np.pi * np.e * var_x / step**2)
            most = 32 / slb
            c = r["compress"]
            print(
                f"| {f} ({what}) | {e} | {c['ratio']:.2f} | {p['sz3']['ratio']:.2f} | "
                f"{p['sperr']['ratio']:.2f} | {c['ratio'] / best:.3f} | {most:.2f} | "
                f"{most / best:.3f} | {c['ratio'] / most:.3f} | {r['dec_mb_s_warm']:.0f} / "
                f"{p['sz3']['dec_mb_s']:.0f} / {p['sperr']['dec_mb_s']:.0f} |"
            )


if __name__ == "__main__":
    main()
