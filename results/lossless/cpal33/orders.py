"""Each candidate order of the tuple palette coded in full (the index volume by the
default lossless codec, one worker, plus the palette chunk), against the order the
encoder's sample picked (measure.csv's ``order``): how much the sample's choice misses.

    PYTHONPATH=. python results/lossless/cpal33/orders.py OUT.csv
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make import volumes  # noqa: E402

from volpack import api  # noqa: E402
from volpack.volume_codec import tuples as tp  # noqa: E402


def main(out_csv: Path) -> None:
    rows = []
    for name, (a, _) in volumes().items():
        series = np.ascontiguousarray(np.moveaxis(a, -1, 0)) if a.shape[-1] <= 4 else a
        tuples, index = tp.find(series)
        row = {"volume": name, "tuples": len(tuples)}
        for order, perm in tp.candidate_orders(tuples, index).items():
            stored = tp.reorder(index, perm)
            row[order] = len(api.compress_array(stored, workers=1)) + len(tp.pack(tuples[perm]))
        print(row, flush=True)
        rows.append(row)
    keys = ["volume", "tuples", *tp.ORDERS]
    with open(out_csv, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main(Path(sys.argv[1]))
