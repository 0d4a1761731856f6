"""A/B of mode 8 (gain combs) in one process: every integer volume of the trial (tuned
ones; the held-out only with --held) and the corpus's integer scans in bricks of 128 as
`volpack compress` cuts them, coded with GAIN off and on: bytes, encode CPU seconds,
which bricks took mode 8, and the decode checked exact.

    PYTHONPATH=. python results/kinds38/ab_gain.py DATA_DIR [--held] [--corpus]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parents[1] / "scripts"))

from volpack import api  # noqa: E402
from volpack.volume_codec import lossless  # noqa: E402


def run(name, a):
    out = []
    for flag in (False, True):
        lossless.GAIN = flag
        t = time.process_time()
        blob = api.compress_array(a, brick=128)
        out.append((len(blob), time.process_time() - t, blob))
    lossless.GAIN = True
    (b0, t0, _), (b1, t1, blob) = out
    assert np.array_equal(api.decompress_array(blob), a)
    from volpack.format.container import Reader

    with Reader(blob) as r:
        tools = r.summary.get("tools", {})
    n8 = sum(v for k, v in tools.items() if k.startswith("gain"))
    kinds = [None] * sum(tools.values())
    print(f"| {name} | {a.dtype} {'x'.join(map(str, a.shape))} | {b0:,} | {b1:,} | {b0 / b1:.4f} | "
          f"{t0:.2f} | {t1:.2f} | {t1 / t0:.3f} | {n8} of {len(kinds)} |", flush=True)  # fmt: skip


def main():
    d = Path(sys.argv[1])
    print(
        "| volume | dtype, shape | bytes GAIN off | on | off / on | encode CPU s off | on | on / off | bricks mode 8 |"
    )
    print("|---|---|---:|---:|---:|---:|---:|---:|---|")
    for line in open(d / "volumes.txt"):
        name, kind, held = line.split("\t")[:3]
        if kind != "int" or ((held == "held") != ("--held" in sys.argv)):
            continue
        run(name, np.load(d / f"{name}.npy"))
    if "--corpus" in sys.argv:
        from datasets import load, names

        for name in names():
            a = load(name)[0]
            if a.dtype.kind in "iu":
                run(name, a)


if __name__ == "__main__":
    main()
