"""Lossy speed of two volpack source trees, interleaved, with SZ3 and SPERR beside each.

Each tree runs in a worker process of its own (``PYTHONPATH`` set to the tree, one BLAS
thread); the workers take turns, never at once. For every field and bound (relative to the
value range, as ``bench_lossy_decode.py``) each worker encodes the field with volpack's
defaults (with ``--effort``, that effort), SPERR (imagecodecs ``sperr_encode(a,
mode="pwe", level=E)``) and SZ3 (pysz, its defaults, absolute bound E), checks the bound on every voxel, then per round decodes the
three in a rotating order, timing each in CPU seconds of its own process
(``time.process_time``); the order of the two workers alternates every round. The best
time of each is kept. ``--encode N`` times the encoders the same way over N rounds.

The figures of merit are ratios taken inside one process, on the same data: volpack's
speed over SZ3's and SPERR's (``x_sz3``, ``x_sperr``), and one tree's volpack over the
other's (``dec_speedup``, ``enc_speedup``: the first tree's best CPU time over the
second's). ``same_bytes`` / ``same_output``: whether the two trees wrote the same stream
and decoded the same voxels.

    python scripts/bench_lossy_ab.py --trees main=/work/main,branch=. \\
        --datasets cam_u,tgv_u --rels 1e-3,1e-4 --rounds 7 --encode 3 --out results/x

Writes ``ab.csv`` (one row per tree and cell, plus the ``dec_speedup`` row fields) and
``ab.md`` in ``--out``.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
METHODS = ("volpack", "sperr", "sz3")


# -- the worker: one tree, commands on stdin, one JSON line out per command ----------


def _worker(effort: str | None = None) -> None:
    sys.path.insert(0, str(HERE))
    import datasets
    from bench_lossy_decode import codecs

    import volpack

    methods = codecs(effort=effort)
    cell = {}

    def reply(obj):
        sys.stdout.write(json.dumps(obj) + "\n")
        sys.stdout.flush()

    def timed_round(kind: str, r: int) -> dict:
        names = list(METHODS)
        names = names[r % 3 :] + names[: r % 3]
        out = {}
        for m in names:
            enc, dec = methods[m]
            call = (lambda: enc(cell["a"], cell["e"])) if kind == "enc" else (
                lambda: dec(cell["blobs"][m], cell["a"])
            )
            t0 = time.process_time()
            call()
            out[m] = time.process_time() - t0
        return out

    reply({"volpack": str(Path(volpack.__file__).parent)})
    for line in sys.stdin:
        cmd = json.loads(line)
        if cmd["op"] == "cell":
            a = np.ascontiguousarray(datasets.load(cmd["name"])[0])
            vrange = float(a.max()) - float(a.min())
            e = float(f"{vrange * cmd['rel']:.4g}")
            blobs = {m: methods[m][0](a, e) for m in METHODS}
            held, digest = {}, ""
            for m in METHODS:
                d = np.asarray(methods[m][1](blobs[m], a))
                held[m] = bool(np.abs(d.astype(np.float64) - a).max() <= e)
                if m == "volpack":
                    digest = hashlib.sha256(np.ascontiguousarray(d).tobytes()).hexdigest()
            cell = {"a": a, "e": e, "blobs": blobs}
            sizes = {
                m: int(b.nbytes) if isinstance(b, np.ndarray) else len(b) for m, b in blobs.items()
            }
            reply({
                "bound": e, "shape": "x".join(map(str, a.shape)), "mb": a.nbytes / 1e6,
                "sizes": sizes, "held": held, "output": digest,
                "stream": hashlib.sha256(bytes(blobs["volpack"])).hexdigest(),
            })  # fmt: skip
        elif cmd["op"] in ("dec", "enc"):
            reply(timed_round(cmd["op"], cmd["round"]))
        else:
            return


# -- the parent ------------------------------------------------------------------------


class Worker:
    def __init__(self, label: str, tree: str, effort: str | None = None):
        env = dict(os.environ, PYTHONPATH=str(Path(tree).resolve()), OPENBLAS_NUM_THREADS="1",
                   OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")  # fmt: skip
        self.label = label
        self.proc = subprocess.Popen(
            [sys.executable, str(Path(__file__).resolve()), "--worker"]
            + ([effort] if effort else []),
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env,
        )  # fmt: skip
        self.where = self.read()["volpack"]

    def ask(self, **cmd):
        self.proc.stdin.write(json.dumps(cmd) + "\n")
        self.proc.stdin.flush()
        return self.read()

    def read(self):
        line = self.proc.stdout.readline()
        if not line:
            raise SystemExit(f"worker {self.label} ended early")
        return json.loads(line)

    def close(self):
        self.proc.stdin.write(json.dumps({"op": "quit"}) + "\n")
        self.proc.stdin.close()
        self.proc.wait()


def best_of(workers, op: str, rounds: int) -> dict:
    """{label: {method: best CPU seconds}} over ``rounds`` rounds, the workers' order
    alternating."""
    best = {w.label: dict.fromkeys(METHODS, math.inf) for w in workers}
    for r in range(rounds):
        for w in workers if r % 2 == 0 else workers[::-1]:
            for m, t in w.ask(op=op, round=r).items():
                best[w.label][m] = min(best[w.label][m], t)
    return best


def run(args) -> list[dict]:
    workers = [Worker(label, tree, args.effort) for label, tree in args.trees]
    for w in workers:
        print(f"{w.label}: volpack from {w.where}", flush=True)
    rows = []
    try:
        for name in args.datasets:
            for rel in args.rels:
                info = {w.label: w.ask(op="cell", name=name, rel=rel) for w in workers}
                dec = best_of(workers, "dec", args.rounds)
                enc = best_of(workers, "enc", args.encode) if args.encode else None
                first, second = workers[0].label, workers[-1].label
                same_bytes = info[first]["stream"] == info[second]["stream"]
                same_out = info[first]["output"] == info[second]["output"]
                for w in workers:
                    i, d = info[w.label], dec[w.label]
                    mb = i["mb"]
                    row = {
                        "tree": w.label, "dataset": name, "shape": i["shape"],
                        "rel_bound": f"{rel:g}", "bound": i["bound"],
                        **{f"ratio_{m}": round(mb * 1e6 / i["sizes"][m], 4) for m in METHODS},
                        **{f"bound_ok_{m}": i["held"][m] for m in METHODS},
                        **{f"dec_MBps_{m}": round(mb / d[m], 2) for m in METHODS},
                        "dec_x_sperr": round(d["sperr"] / d["volpack"], 3),
                        "dec_x_sz3": round(d["sz3"] / d["volpack"], 3),
                        "dec_speedup": round(dec[first]["volpack"] / d["volpack"], 3),
                        "same_bytes": same_bytes, "same_output": same_out,
                    }  # fmt: skip
                    if enc:
                        e = enc[w.label]
                        row.update({f"enc_MBps_{m}": round(mb / e[m], 3) for m in METHODS})
                        row["enc_x_sperr"] = round(e["sperr"] / e["volpack"], 4)
                        row["enc_x_sz3"] = round(e["sz3"] / e["volpack"], 4)
                        row["enc_speedup"] = round(enc[first]["volpack"] / e["volpack"], 3)
                    rows.append(row)
                r2 = rows[-1]
                print(
                    f"{name:16s} {rel:6g} ratio {r2['ratio_volpack']:7.2f} same bytes "
                    f"{same_bytes} output {same_out} | dec {second}/{first} "
                    f"{r2['dec_speedup']:.3f} x SZ3 {rows[-2]['dec_x_sz3']:.3f} -> "
                    f"{r2['dec_x_sz3']:.3f} x SPERR {rows[-2]['dec_x_sperr']:.3f} -> "
                    f"{r2['dec_x_sperr']:.3f}"
                    + (f" | enc {second}/{first} {r2['enc_speedup']:.3f}" if enc else ""),
                    flush=True,
                )
    finally:
        for w in workers:
            w.close()
    return rows


def write(rows: list[dict], out: Path, args) -> None:
    out.mkdir(parents=True, exist_ok=True)
    fields = list(dict.fromkeys(k for r in rows for k in r))
    with (out / "ab.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    labels = [lbl for lbl, _ in args.trees]
    first, second = labels[0], labels[-1]
    enc = args.encode > 0
    lines = [
        f"# {second} against {first}: lossy speed, one core, interleaved, best CPU time",
        "",
        "`python scripts/bench_lossy_ab.py " + " ".join(sys.argv[1:]) + "`",
        "",
        f"x SZ3 / x SPERR: volpack's decode speed over the peer's, in the same process; "
        f"speed-up: {first}'s best CPU time over {second}'s.",
        "",
        "| field | bound | ratio | same bytes | dec MB/s "
        + f"{first} / {second} | dec speed-up | x SZ3 {first} / {second} | x SPERR "
        + f"{first} / {second} |"
        + (f" enc MB/s {first} / {second} | enc speed-up |" if enc else ""),
        "|---|---|---:|---|---:|---:|---:|---:|" + ("---:|---:|" if enc else ""),
    ]
    by = {(r["dataset"], r["rel_bound"], r["tree"]): r for r in rows}
    for name in args.datasets:
        for rel in args.rels:
            a, b = by[name, f"{rel:g}", first], by[name, f"{rel:g}", second]
            line = (
                f"| {name} | {rel:g} | {b['ratio_volpack']:.2f} | "
                f"{'yes' if b['same_bytes'] and b['same_output'] else 'NO'} | "
                f"{a['dec_MBps_volpack']:.1f} / {b['dec_MBps_volpack']:.1f} | "
                f"{b['dec_speedup']:.3f} | {a['dec_x_sz3']:.3f} / {b['dec_x_sz3']:.3f} | "
                f"{a['dec_x_sperr']:.3f} / {b['dec_x_sperr']:.3f} |"
            )
            if enc:
                line += (
                    f" {a['enc_MBps_volpack']:.2f} / {b['enc_MBps_volpack']:.2f} |"
                    f" {b['enc_speedup']:.3f} |"
                )
            lines.append(line)
    (out / "ab.md").write_text("\n".join(lines) + "\n")


def main(argv=None) -> None:
    if argv is None and sys.argv[1:2] == ["--worker"]:
        _worker(*sys.argv[2:3])
        return
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--trees", required=True, help="label=path,label=path (first: the base)")
    ap.add_argument("--datasets", default="cam_u,tgv_u,climate_t")
    ap.add_argument("--rels", default="1e-3,1e-4")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--encode", type=int, default=0, metavar="N")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--effort", default=None, help="volpack's encoder effort (default: its own)")
    args = ap.parse_args(argv)
    args.trees = [tuple(t.split("=", 1)) for t in args.trees.split(",") if t]
    args.datasets = [d for d in args.datasets.split(",") if d]
    args.rels = [float(r) for r in args.rels.split(",") if r]
    rows = run(args)
    write(rows, args.out, args)


if __name__ == "__main__":
    main()
