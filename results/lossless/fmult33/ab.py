"""The lattice step from the smallest magnitude (floatpredict.MAGNITUDE_STEP) off and on.

Every float field of scripts/datasets.py up to 3 M voxels, whole and at every second
voxel, coded exactly with both settings in one process (one worker); each file decoded bit
for bit; where the bytes differ, the best lossless peer of ``volpack compare --peers``
(pcodec, fpzip, zstd, blosc2) on the same array. Writes OUT.csv.

Run: PYTHONPATH=. python results/lossless/fmult33/ab.py OUT.csv [NAMES]
"""

import csv
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
from datasets import DATASETS, load  # noqa: E402

from volpack import api  # noqa: E402
from volpack.compare import compare_peers  # noqa: E402
from volpack.volume_codec import floatpredict  # noqa: E402


def encode(a: np.ndarray, on: bool) -> tuple[bytes, float]:
    floatpredict.MAGNITUDE_STEP = on
    t = time.process_time()
    blob = api.compress_array(a, workers=1)
    t = time.process_time() - t
    assert np.array_equal(api.decompress_array(blob).view(np.uint8), a.view(np.uint8))
    return blob, t


def main(out: str, names: list[str]) -> None:
    rows = []
    for name in names:
        v = np.asarray(load(name)[0])
        for kind, a in (("whole", v), ("every 2nd", v[::2, ::2, ::2])):
            a = np.ascontiguousarray(a)
            if a.size > 3_000_000:
                continue
            before, t0 = encode(a, False)
            after, t1 = encode(a, True)
            row = {"field": name, "kind": kind, "shape": "x".join(map(str, a.shape)),
                   "before": len(before), "after": len(after),
                   "gain": round(len(before) / len(after), 4),
                   "cpu_before": round(t0, 3), "cpu_after": round(t1, 3)}  # fmt: skip
            if len(before) != len(after):
                peers, _ = compare_peers(a, jpegxl_efforts=())
                best = max(peers, key=lambda p: p["ratio"])
                row.update(peer=best["name"], peer_bytes=best["nbytes"] if "nbytes" in best else round(a.nbytes / best["ratio"]),
                           x_before=round(a.nbytes / len(before) / best["ratio"], 4),
                           x_after=round(a.nbytes / len(after) / best["ratio"], 4))  # fmt: skip
            print(row, flush=True)
            rows.append(row)
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    floats = [n for n, d in DATASETS.items() if d.kind == "float"]
    main(sys.argv[1], sys.argv[2].split(",") if len(sys.argv) > 2 else floats)
