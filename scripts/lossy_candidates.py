"""Every coding the bounded encoder makes of a field, its bytes and its decoding speed.

For each float field and bound (relative to the value range; single-brick fields), the
default encoder's ``keep_faster`` is watched to list the codings it chose among (decoding
tier, payload kind, bytes); then the field is encoded once more per coding with that
coding forced (and once with the interpolation path's static bins forced), every
stream's bound is checked on every voxel, and all of them and SPERR (imagecodecs
``pwe``) decode in turns, best of ``--rounds`` CPU times in this process. So one sees,
per cell, what a faster coding would cost in bytes and give in speed against SPERR.

    python scripts/lossy_candidates.py --datasets tgv_pressure,mri_piesno_noise --rels 1e-2

Writes ``candidates.csv`` in ``--out``.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402
from bench_lossy_decode import best_interleaved, codecs, payload_paths  # noqa: E402

FIELDS = ["dataset", "rel_bound", "coding", "tier", "payload", "bytes", "vs_default",
          "ratio", "x_sperr", "default"]  # fmt: skip


def watch():
    """Patch the encoder: returns a dict whose ``force`` picks a candidate (or None) and
    whose ``seen`` lists each ``keep_faster`` call's candidates; ``static`` forces the
    interpolation path's static bins."""
    from volpack.volume_codec import bounded_interp, lossy

    state = {"force": None, "seen": [], "static": False}
    keep, interp = lossy.keep_faster, bounded_interp.encode

    def keep_faster(cands):
        state["seen"].append([(t, m[0][0], len(m[0])) for t, m in cands])
        return cands[state["force"]][1] if state["force"] is not None else keep(cands)

    def encode(g, step, tried=bounded_interp.TRIED, codings=bounded_interp.CODINGS, **kw):
        return interp(g, step, tried, ("static",) if state["static"] else codings, **kw)

    lossy.keep_faster, bounded_interp.encode = keep_faster, encode
    return state


def run_cell(state, methods, name, a, rel, rounds) -> list[dict]:
    e = rel * float(a.max() - a.min())
    enc = methods["volpack"][0]
    state.update(force=None, static=False, seen=[])
    streams = {"default": enc(a, e)}
    if len(state["seen"]) != 1:
        raise SystemExit(f"{name}: {len(state['seen'])} choices (one brick only here)")
    cands = state["seen"][0]
    for i in range(len(cands)):
        state["force"] = i
        streams[f"c{i}"] = enc(a, e)
    state.update(force=None, static=True)
    streams["static bins"] = enc(a, e)
    state["static"] = False
    from volpack import api

    for k, b in streams.items():
        if np.abs(api.decompress_array(b).astype(np.float64) - a).max() > e:
            raise AssertionError(f"{name} {rel} {k}: the bound is missed")
    sp = methods["sperr"][0](a, e)
    calls = {k: (lambda b=b: api.decompress_array(b)) for k, b in streams.items()}
    calls["sperr"] = lambda: methods["sperr"][1](sp, a)
    best = best_interleaved(calls, rounds)
    rows = []
    for k, b in streams.items():
        i = int(k[1:]) if k.startswith("c") else None
        rows.append({
            "dataset": name, "rel_bound": rel, "coding": k,
            "tier": cands[i][0] if i is not None else "", "payload": payload_paths(b),
            "bytes": len(b), "vs_default": len(b) / len(streams["default"]) - 1,
            "ratio": a.nbytes / len(b), "x_sperr": best["sperr"] / best[k],
            "default": b == streams["default"],
        })  # fmt: skip
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--datasets", default="tgv_pressure,mri_piesno_noise,cam_u")
    ap.add_argument("--rels", default="1e-2,1e-3,1e-4")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--out", default="results/lossy/lossy14")
    args = ap.parse_args(argv)
    state, methods = watch(), codecs()
    rows = []
    for name in args.datasets.split(","):
        a = datasets.load(name)[0]
        for rel in (float(r) for r in args.rels.split(",")):
            cell = run_cell(state, methods, name, a, rel, args.rounds)
            rows += cell
            for r in cell:
                print(
                    f"{name:16s} {rel:<7g} {r['coding']:11s} tier {r['tier']!s:2s}"
                    f" {r['payload'][:42]:42s} {r['bytes']:8d} B {r['vs_default']:+8.2%}"
                    f" x SPERR {r['x_sperr']:.2f}{'  (default)' if r['default'] else ''}",
                    flush=True,
                )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "candidates.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=FIELDS)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in r.items()})
    return 0


if __name__ == "__main__":
    sys.exit(main())
