"""Tuple palettes before and after, in one process: ``tuples=False`` (the channels coded
as a series, main's default at f0fa4af) against the default, interleaved, best of N by
CPU time (time.process_time, one worker); every stream decoded and compared bit for bit;
the lossless peers of ``volpack compare --peers`` (volpack.compare.compare_peers) run
once on each volume.

    PYTHONPATH=. python results/lossless/cpal33/measure.py OUT.csv [N [NAME ...]]
"""

from __future__ import annotations

import csv
import io
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make import volumes  # noqa: E402

from volpack import api  # noqa: E402
from volpack.compare import compare_peers  # noqa: E402
from volpack.volume_codec import stream  # noqa: E402


def fluo() -> tuple[np.ndarray, str]:
    from scipy import ndimage

    rng = np.random.default_rng(3333)
    img = np.zeros((40, 160, 160))
    img[tuple(rng.integers(0, s, 250) for s in img.shape)] = 1.0
    nuc = ndimage.gaussian_filter(img, 2.5) * (2 * np.pi * 2.5**2) ** 1.5
    two = np.stack([rng.poisson(nuc * 1500 + 80), rng.poisson(nuc[::-1] * 600 + 60)], -1)
    return two.astype(np.uint16), "two Poisson fluorescence channels, uint16, last (no palette: too many tuples)"


def cpu(f):
    t = time.process_time()
    out = f()
    return time.process_time() - t, out


def encode(a, opts):
    buf = io.BytesIO()
    st = stream.compress(a, buf, workers=1, **opts)
    return buf.getvalue(), st


def main(out_csv: Path, n: int, names: list[str]) -> None:
    vols = volumes()
    vols["fluo2_fallback"] = fluo()
    if names:
        vols = {k: v for k, v in vols.items() if k in names}
    api.compress_array(np.zeros((8, 16, 16, 3), np.uint8) + np.arange(16, dtype=np.uint8)[:, None])
    rows = []
    for name, (a, text) in vols.items():
        row = {"volume": name, "dtype": str(a.dtype), "shape": "x".join(map(str, a.shape)),
               "tuned": name == "ch2_rgb_zyxc", "description": text}
        enc = {"before": [], "after": []}
        blobs, stats = {}, {}
        for _ in range(n):  # interleaved
            for tag, opts in (("before", {"tuples": False}), ("after", {})):
                t, (blob, st) = cpu(lambda o=opts, a=a: encode(a, o))
                enc[tag].append(t)
                blobs[tag], stats[tag] = blob, st
        for tag in ("before", "after"):
            dec = []
            for _ in range(n):
                t, back = cpu(lambda b=blobs[tag]: api.decompress_array(b, workers=1))
                dec.append(t)
            assert back.dtype == a.dtype and back.shape == a.shape and back.tobytes() == a.tobytes(), (name, tag)
            row[f"{tag}_bytes"] = len(blobs[tag])
            row[f"{tag}_ratio"] = round(a.nbytes / len(blobs[tag]), 3)
            row[f"{tag}_enc_cpu_s"] = round(min(enc[tag]), 3)
            row[f"{tag}_dec_cpu_s"] = round(min(dec), 3)
        st = stats["after"]
        row["tuples"] = st.get("tuples", "")
        row["order"] = st.get("tuple_order", "")
        row["gain"] = round(row["before_bytes"] / row["after_bytes"], 3)
        peers, _ = compare_peers(a)
        best = max((p for p in peers if p.get("lossless")), key=lambda p: p["ratio"])
        row["best_peer"] = best["name"]
        row["best_peer_ratio"] = round(best["ratio"], 3)
        row["before_x_peer"] = round(row["before_ratio"] / best["ratio"], 3)
        row["after_x_peer"] = round(row["after_ratio"] / best["ratio"], 3)
        print(row, flush=True)
        rows.append(row)
        with open(out_csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    args = sys.argv[1:]
    main(Path(args[0]), int(args[1]) if len(args) > 1 else 2, args[2:])
