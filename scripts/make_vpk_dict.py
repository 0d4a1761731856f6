"""Train the zstd dictionary that format version 2 of the ``.vpk`` container codes its
header and summary JSON against (``formats/vpk-2.md``, section 4).

Samples: the header and summary of every golden example in ``formats/examples/`` (every
stream kind), and of the float fields volpack's settings were tuned and validated on
(``scripts/bench_lossy.py``: TUNE_FIELDS and VALIDATION_FIELDS; the held-out fields are
left out), coded at max error 1e-2 .. 1e-5 of their value range and losslessly.

A shipped dictionary never changes (files written with it must stay readable): this
script writes to ``--out`` and refuses to overwrite; a new dictionary needs a new format
version. ``volpack/data/vpk-dict-1.zdict`` was made by

    python scripts/make_vpk_dict.py --out volpack/data/vpk-dict-1.zdict
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))

SIZE = 8192  # bytes; on held-out headers 2048 / 4096 / 8192 / 16384 code to 54 / 52 / 50 / 53 bytes


def _text(obj: dict) -> bytes:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=False).encode()


def samples(fields: list[str]) -> list[bytes]:
    from volpack import api
    from volpack.format import compact
    from volpack.format.container import Reader

    # the samples are written without the dictionary they will train (plain JSON text)
    compact.pack_text = lambda text: (compact.TEXT_JSON, text)
    out = []
    for path in sorted((ROOT / "formats" / "examples").glob("*.vpk")):
        with Reader(str(path)) as r:
            out += [_text(r.header), _text(r.summary or {})]
    import datasets

    for name in fields:
        a, _, _ = datasets.load(name)
        finite = a[np.isfinite(a)]
        rng = float(finite.max() - finite.min()) if finite.size else 1.0
        blobs = [api.compress_array(a)]
        blobs += [api.compress_array(a, max_error=float(f"{rel * rng:.4g}")) for rel in
                  (1e-2, 1e-3, 1e-4, 1e-5)]  # fmt: skip
        for blob in blobs:
            with Reader(blob) as r:
                out += [_text(r.header), _text(r.summary or {})]
        print(f"{name}: {len(out)} samples", file=sys.stderr)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--fields", default=None, help="comma-separated (default: tune + validation)")
    ap.add_argument("--size", type=int, default=SIZE, help="dictionary bytes")
    ap.add_argument("--samples", type=Path, help="keep the samples here (JSON) / reuse them")
    args = ap.parse_args()
    if args.out.exists():
        ap.error(f"{args.out} exists: a shipped dictionary never changes")
    import bench_lossy
    import zstandard

    fields = (
        args.fields.split(",")
        if args.fields
        else bench_lossy.TUNE_FIELDS + bench_lossy.VALIDATION_FIELDS
    )
    if args.samples and args.samples.exists():
        data = [s.encode() for s in json.loads(args.samples.read_text())]
    else:
        data = samples(fields)
        if args.samples:
            args.samples.write_text(json.dumps([s.decode() for s in data]))
    # zstd's trainer wants many samples; repeating the set keeps its statistics
    d = zstandard.train_dictionary(args.size, data * max(1, 400 // len(data)), level=19)
    args.out.write_bytes(d.as_bytes())
    print(f"{args.out}: {len(d.as_bytes())} bytes from {len(data)} samples")
    return 0


if __name__ == "__main__":
    sys.exit(main())
