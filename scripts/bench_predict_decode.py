"""Decode cost of the default lossless codec per tool: CPU seconds, per voxel and per
coded binary decision, against JPEG-LS in the same process.

For each volume: the default codec (``api.compress_array``, 64^3 bricks) encodes once
(the blob is kept in ``--blobs`` so that runs of two checkouts decode the same bytes,
and so that the bytes can be compared: ``sha256`` column); then, best of ``--repeat``,
interleaved round by round:

* the whole volume, ``api.decompress_array(workers=1)``: CPU seconds
  (``time.process_time``), MB/s per core (1e6 bytes of raw voxels);
* each tool's bricks (``volpack info``'s names) decoded one by one through the codec,
  CPU seconds summed per tool;
* JPEG-LS (CharLS through imagecodecs, per z slice; signed volumes shifted first).

For the version-2 predictive bricks it also counts the binary decisions the range coder
decodes (zero flag, sign, unary bit length, two mantissa bits; the plain low bits are
counted apart), by running the predictor over the known voxels.

Before/after: run it with ``PYTHONPATH`` set to each checkout in turn, with the same
``--blobs``, and another ``--label``; ``--check-bytes`` makes a run encode again and
fail unless its blob equals the stored one byte for byte.

    PYTHONPATH=. python scripts/bench_predict_decode.py ct_head mri_ch2better \\
        --label after --out results/lossless/arith8
"""

from __future__ import annotations

import argparse
import collections
import csv
import hashlib
import os
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

FIELDS = [
    "label", "dataset", "shape", "dtype", "ratio", "jpegls_ratio", "cpu_s", "mb_s",
    "jpegls_cpu_s", "jpegls_mb_s", "vs_jpegls", "tool", "tool_voxels", "tool_cpu_s",
    "tool_mb_s", "ns_per_voxel", "decisions", "raw_bits", "ns_per_decision", "sha256",
    "load",
]  # fmt: skip


def _decisions():
    """A kernel counting the version-2 predictive coder's binary decisions and plain bits
    over known voxels (the encoder's loop without the coder)."""
    from volpack._jit import kernel
    from volpack.volume_codec import predictfit as pf
    from volpack.volume_codec.predict import bitlen

    @kernel(nrt=False)  # (numba's reference counts in the loop would cost more than it)
    def count(v, mk, cf, th, shape, hi, err, perr, bias_sum, bias_cnt, bias):
        nz, ny, nx = shape[0], shape[1], shape[2]
        sz = ny * nx
        dec = 0
        raw = 0
        z0 = np.int64(0)
        held = (z0, z0, z0, z0, z0, z0, z0, z0)
        i = 0
        for z in range(nz):
            cur = (z & 1) * sz
            prev = sz - cur
            for y in range(ny):
                for x in range(nx):
                    r = cur + y * nx + x
                    if mk[np.uint64(i)]:
                        held = pf._skip(err, perr, r, v[np.uint64(i)])
                        i += 1
                        continue
                    pred, ctx, sctx, q0, q1, q2, q3, q4, q5 = pf._predict_kernel(
                        v, cf, th, err, perr, i, r, r - cur + prev, z, y, x, ny, nx, hi, bias, held
                    )
                    val = v[np.uint64(i)]
                    res = val - pred
                    dec += 1
                    if res != 0:
                        nb = bitlen(abs(res) - 1)
                        nm = max(min(nb - 1, 2), 0)
                        dec += 1 + min(nb + 1, pf.NLEN - 1) + nm
                        raw += max(nb - 1 - nm, 0)
                    held = pf._learn(
                        err, perr, r, val, pred, ctx, bias_sum, bias_cnt, bias, q0, q1, q2, q3, q4, q5
                    )
                    i += 1
        return dec, raw

    return count


def count_decisions(payload: bytes, brick: np.ndarray) -> tuple[int, int]:
    """Binary decisions and plain bits of a version-2 predictive brick payload (0, 0 for
    other tools)."""
    from volpack.volume_codec import bgmask, lossless, predictfit
    from volpack.volume_codec import palette as pal

    if payload[0] != lossless.MODE_PREDICT or not payload[1] & lossless.FLAG_FIT:
        return 0, 0
    flags = payload[1]
    rest = memoryview(payload)[2:]
    v = brick.astype(np.int64)
    if flags & lossless.FLAG_PALETTE:
        p, used = pal.unpack(rest, min(pal.MAX_PALETTE, brick.size))
        v = np.searchsorted(p, v)
        lo, hi = 0, len(p) - 1
    else:
        vmin, vmax = lossless._value_range(brick.dtype)
        lo, hi, used = pal.read_range(rest, vmin, vmax, "bench")
    rest = rest[used:]
    mask = np.zeros(brick.shape, dtype=bool)
    if flags & lossless.FLAG_MASK:
        _, mask, used = bgmask.decode(rest, brick.shape, hi - lo)
        rest = rest[used:]
    head = bytes(rest[: predictfit.HEAD])
    th = np.frombuffer(head, dtype="<u4", count=predictfit.NCLS - 1).astype(np.int64)
    cf = np.frombuffer(head, dtype="<i2", count=predictfit.NCLS * predictfit.NFIT, offset=4 * (predictfit.NCLS - 1))
    *work, _ = predictfit._workspace(brick.shape)
    dec, raw = _decisions()(
        (v - lo).reshape(-1), mask.reshape(-1).astype(np.uint8), cf.astype(np.int64), th,
        np.array(brick.shape, dtype=np.int64), np.int64(hi - lo), *work,
    )  # fmt: skip
    return int(dec), int(raw)


def load_blob(name: str, a: np.ndarray, blobs: Path, check: bool) -> bytes:
    from volpack import api

    path = blobs / f"{name}.vpk"
    if path.exists() and not check:
        return path.read_bytes()
    blob = api.compress_array(a)
    if path.exists() and path.read_bytes() != blob:
        raise AssertionError(f"{name}: this checkout's encoder wrote other bytes than {path}")
    blobs.mkdir(parents=True, exist_ok=True)
    path.write_bytes(blob)
    return blob


def measure(name: str, repeat: int, label: str, blobs: Path, check: bool, decisions: bool) -> list[dict]:
    import datasets
    import imagecodecs as ic

    from volpack import api
    from volpack.format.container import Reader
    from volpack.volume_codec import bricks
    from volpack.volume_codec.registry import get_codec

    a, _, _ = datasets.load(name)
    a = np.ascontiguousarray(a)
    blob = load_blob(name, a, blobs, check)
    back = api.decompress_array(blob, workers=1)
    if not np.array_equal(back, a):
        raise AssertionError(f"{name}: volpack did not round-trip")
    with Reader(blob) as r:
        c = get_codec(r.header["codec"])
        bshape = tuple(r.header["brick"])
        items = []
        for e in r.entries:
            sl = bricks.brick_slices(a.shape, bshape, e.node)
            items.append((r.read(e.t, e.node), a[sl]))
    shift = 1 << (8 * a.itemsize - 1) if a.dtype.kind == "i" else 0
    u = (a.astype(np.int64) + shift).astype(f"u{a.itemsize}")
    enc = [ic.jpegls_encode(s) for s in u]

    tvol = tj = float("inf")
    ttool: dict[str, float] = {}
    for _ in range(repeat):  # interleaved: a burst of load hurts every measure alike
        t = time.process_time()
        api.decompress_array(blob, workers=1)
        tvol = min(tvol, time.process_time() - t)
        t = time.process_time()
        for e in enc:
            ic.jpegls_decode(e)
        tj = min(tj, time.process_time() - t)
        sums: dict[str, float] = collections.defaultdict(float)
        for p, b in items:
            t = time.process_time()
            c.decode(p, b.shape, a.dtype)
            sums[c.describe(p)] += time.process_time() - t
        for k, s in sums.items():
            ttool[k] = min(ttool.get(k, float("inf")), s)

    vox: dict[str, int] = collections.defaultdict(int)
    dec: dict[str, list[int]] = collections.defaultdict(lambda: [0, 0])
    for p, b in items:
        k = c.describe(p)
        vox[k] += b.size
        d, rb = count_decisions(p, b) if decisions else (0, 0)
        dec[k][0] += d
        dec[k][1] += rb
    mb = a.nbytes / 1e6
    base = {
        "label": label,
        "dataset": name,
        "shape": "x".join(map(str, a.shape)),
        "dtype": str(a.dtype),
        "ratio": round(a.nbytes / len(blob), 3),
        "jpegls_ratio": round(a.nbytes / sum(map(len, enc)), 3),
        "cpu_s": round(tvol, 4),
        "mb_s": round(mb / tvol, 2),
        "jpegls_cpu_s": round(tj, 4),
        "jpegls_mb_s": round(mb / tj, 2),
        "vs_jpegls": round(tj / tvol, 3),
        "sha256": hashlib.sha256(blob).hexdigest()[:16],
        "load": f"{os.getloadavg()[0]:.1f}",
    }
    rows = []
    for k in sorted(ttool):
        t = ttool[k]
        d, rb = dec[k]
        rows.append({
            **base,
            "tool": k,
            "tool_voxels": vox[k],
            "tool_cpu_s": round(t, 4),
            "tool_mb_s": round(vox[k] * a.itemsize / 1e6 / t, 2) if t > 0 else "",
            "ns_per_voxel": round(1e9 * t / vox[k], 2),
            "decisions": d,
            "raw_bits": rb,
            "ns_per_decision": round(1e9 * t / d, 2) if d else "",
        })  # fmt: skip
    return rows


def write(rows: list[dict], out: Path, name: str) -> None:
    out.mkdir(parents=True, exist_ok=True)
    path = out / name
    old = []
    if path.exists():
        with path.open() as f:
            old = list(csv.DictReader(f))
    keys = {(r["label"], r["dataset"], r["tool"]) for r in rows}
    allrows = [r for r in old if (r["label"], r["dataset"], r["tool"]) not in keys] + rows
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        w.writeheader()
        w.writerows(allrows)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("datasets", nargs="*", default=["ct_head"])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--label", default="run")
    ap.add_argument("--blobs", type=Path, default=Path(os.environ.get("TMPDIR", "/tmp")) / "vpk_blobs")
    ap.add_argument("--check-bytes", action="store_true", help="encode again; fail on other bytes")
    ap.add_argument("--out", type=Path, default=HERE.parent / "results" / "lossless" / "arith8")
    ap.add_argument("--csv", default="decode_tools.csv")
    ap.add_argument(
        "--no-decisions", action="store_true",
        help="do not count decisions (the count uses this checkout's kernels: for another checkout)",
    )  # fmt: skip
    args = ap.parse_args(argv)
    import volpack

    print("volpack from", volpack.__file__, flush=True)
    rows = []
    for name in args.datasets:
        got = measure(name, args.repeat, args.label, args.blobs, args.check_bytes, not args.no_decisions)
        for r in got:
            print({k: r[k] for k in ("dataset", "tool", "mb_s", "vs_jpegls", "tool_mb_s",
                                     "ns_per_voxel", "ns_per_decision", "sha256")}, flush=True)  # fmt: skip
        rows += got
    write(rows, args.out, args.csv)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
