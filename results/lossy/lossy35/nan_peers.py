"""The NaN fields against the peers, which refuse NaN: the peers (`volpack compare
--peers`, the same bound E = rel x the finite range) given the field with its NaN filled
(sst_nan: by -1.8, its land value in the source; storm_u_nan: by 0, inside its range), volpack
as the trial ran it on the NaN field (NaN kept exactly). An approximation: the peers code
a constant where volpack codes a mask.

Run: PYTHONPATH=. python results/lossy/lossy35/nan_peers.py DIR trial_base.csv trial_heldout.csv
"""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

FILL = {"sst_nan": -1.8, "storm_u_nan": 0.0}


def main() -> None:
    d = Path(sys.argv[1])
    ours = {(r["field"], r["rel"]): r for p in sys.argv[2:] for r in csv.DictReader(open(p))}
    print("| field | E | volpack (NaN kept) bytes | SZ3 (filled) | SPERR (filled) | x best |")
    print("|---|---|---|---|---|---|")
    for name, fill in FILL.items():
        x = np.load(d / f"{name}.npy")
        span = float(np.nanmax(x) - np.nanmin(x))
        filled = np.where(np.isnan(x), np.float32(fill), x).astype(x.dtype)
        f = d / f"{name}_filled.npy"
        np.save(f, filled)
        for rel in ("1e-2", "1e-3", "1e-4", "1e-5"):
            e = float(rel) * span
            cmd = [sys.executable, "-m", "volpack", "-q", "compare", str(f), "--max-error",
                   repr(e), "--peers", "--json"]  # fmt: skip
            j = json.loads(subprocess.run(cmd, capture_output=True, text=True, check=True).stdout)
            peer = {q["name"]: q for q in j["peers"]}
            ok = {n: q["file_nbytes"] for n, q in peer.items() if n in ("sz3", "sperr") and q["bound_held"]}
            mine = int(ours[name, rel]["bytes"])
            best = min(ok.values()) if ok else None
            cell = {n: (f"{peer[n]['file_nbytes']:,}" + ("" if peer[n]["bound_held"] else " (broken)")) for n in ("sz3", "sperr") if n in peer}
            xb = f"{best / mine:.3f}" if best else "-"
            print(f"| {name} | {rel} | {mine:,} | {cell.get('sz3')} | {cell.get('sperr')} | {xb} |", flush=True)


if __name__ == "__main__":
    main()
