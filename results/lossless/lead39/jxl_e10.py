"""JPEG-XL lossless at effort 10 (libjxl's highest) on the integer volumes of a trial whose
peers ran at efforts 7 and 9 only: does the best peer change, and by how much?

    python results/lossless/lead39/jxl_e10.py VOLDIR TRIAL.csv [TRIAL.csv ...] > OUT.csv

Each volume VOLDIR/<name>.npy of the trial CSVs' integer rows (no ``rel``) is coded by the
peer exactly as ``volpack compare --jpegxl-efforts 10`` runs it (``volpack.peers``), decoded
and checked equal; volpack's ratio and the best peer's are the trial's own.
"""

from __future__ import annotations

import csv
import sys
import time
from pathlib import Path

import numpy as np

from volpack import peers


def main() -> None:
    vols, trials = Path(sys.argv[1]), sys.argv[2:]
    out = csv.writer(sys.stdout)
    out.writerow(["name", "set", "volpack", "best_peer", "peer_ratio", "e10_ratio",
                  "e10_encode_s", "best_with_e10", "x_best_with_e10"])  # fmt: skip
    for path in trials:
        for row in csv.DictReader(open(path)):
            if row["rel"]:
                continue
            a = np.load(vols / f"{row['name']}.npy")
            (peer,) = [p for p in peers.lossless(a.dtype, a.shape, jpegxl_efforts=(10,))[0]
                       if p.name == "jpegxl-e10"]  # fmt: skip
            t = time.process_time()
            blob = peer.encode(a)
            secs = time.process_time() - t
            if not np.array_equal(peer.decode(blob), a):
                raise SystemExit(f"{row['name']}: JPEG-XL e10 did not round-trip")
            r10 = a.nbytes / peers.nbytes(blob)
            best = max(float(row["peer_ratio"]), r10)
            out.writerow([row["name"], row["set"], row["ratio"], row["best_peer"],
                          row["peer_ratio"], f"{r10:.4f}", f"{secs:.1f}",
                          "jpegxl-e10" if r10 > float(row["peer_ratio"]) else row["best_peer"],
                          f"{float(row['ratio']) / best:.4f}"])  # fmt: skip
            sys.stdout.flush()


if __name__ == "__main__":
    main()
