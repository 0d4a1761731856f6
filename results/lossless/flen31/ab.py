"""The lossless encode of float volumes, before (the base tree 3430757's codec, imported
as ``volpack_base`` from a copy) against this tree's exact mode (``lossless.PRUNE_FLOAT =
False``: the same choices, faster code) and its default (pruned), interleaved in one
process: CPU seconds (``time.process_time``) and payload bytes of every 128^3 brick's
``LosslessCodec().encode`` summed per volume; every pruned payload decoded and compared
bit for bit.

    mkdir -p /tmp/base && git archive 3430757 volpack | tar -x -C /tmp/base
    mv /tmp/base/volpack /tmp/base/volpack_base
    PYTHONPATH=.:/tmp/base python results/lossless/flen31/ab.py OUT.csv NAME_OR_NPY... [--rounds N]
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from tools_profile import volume  # noqa: E402
from variants import bricks  # noqa: E402

from volpack.volume_codec import lossless  # noqa: E402

try:
    from volpack_base.volume_codec import lossless as base
except ImportError:  # no copy of the base tree: its rows are left out
    base = None


def encode(bs, mode):
    if mode == "before":
        codec = base.LosslessCodec()
    else:
        lossless.PRUNE_FLOAT = mode == "pruned"
        codec = lossless.LosslessCodec()
    t = time.process_time()
    out = [codec.encode(b) for b in bs]
    return out, time.process_time() - t


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("volumes", nargs="+")
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--modes", default="before,exact,pruned")
    args = ap.parse_args()
    modes = [m for m in args.modes.split(",") if m != "before" or base is not None]
    warm = [b for _, b in bricks(volume("ct_skull_float")[:40])]
    for m in modes:
        encode(warm, m)  # the kernels compile on first use
    ratios = []
    with open(args.out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(
            ["volume", "shape", "bricks"]
            + [f"{k}_{m}" for m in modes for k in ("bytes", "cpu")]
            + ["same", "tools"]
        )
        for spec in args.volumes:
            a = volume(spec)
            bs = [b for _, b in bricks(a)]
            best = {m: math.inf for m in modes}
            size, payloads = {}, {}
            for _ in range(args.rounds):
                for m in modes:
                    out, cpu = encode(bs, m)
                    best[m] = min(best[m], cpu)
                    size[m], payloads[m] = sum(map(len, out)), out
            codec = lossless.LosslessCodec()
            for b, p in zip(bs, payloads["pruned"]):
                d = codec.decode(p, b.shape, b.dtype)
                assert d.tobytes() == b.tobytes(), spec
            ref = "before" if "before" in modes else "exact"
            same = all(x == y for x, y in zip(payloads[ref], payloads["pruned"]))
            exact_same = "before" not in modes or payloads["before"] == payloads.get(
                "exact", payloads["before"]
            )
            tools = " ".join(sorted(set(lossless.describe(p) for p in payloads["pruned"])))
            row = [spec, "x".join(map(str, a.shape)), len(bs)]
            for m in modes:
                row += [size[m], round(best[m], 3)]
            w.writerow(row + [f"{same}/{exact_same}", tools])
            f.flush()
            ratios.append(best[ref] / best["pruned"])
            d = 100 * (size["pruned"] / size[ref] - 1)
            print(
                f"{spec:18s} {' '.join(f'{m} {size[m]} {best[m]:.2f}s' for m in modes)}  "
                f"x{best[ref] / best['pruned']:.2f} {d:+.3f}% same {same} exact-same {exact_same} {tools}",
                flush=True,
            )
    print(
        f"geometric mean {math.exp(sum(map(math.log, ratios)) / len(ratios)):.3f}x over {len(ratios)}"
    )


if __name__ == "__main__":
    main()
