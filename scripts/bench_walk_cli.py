"""`volpack walk` as a user runs it, per frame and per process: two source trees
(e.g. an export of main and this branch) alternating, round after round.

For each round, volume and configuration, runs ``volpack walk TREE.vpk OUT/ --orbit N
--json`` in a fresh process (PNG frames written, 512x512, auto TF, Phong) with the
configuration's PYTHONPATH and extra options, and records each frame's select / decode
/ render milliseconds and CPU, nodes drawn and decoded and refinements held back, when
frame 0 was done since the process started (``finished_at``, walk18 on) and when its PNG
appeared in the output folder after the spawn (polled, every tree), and the process's
wall, user and system seconds (``resource.getrusage`` of the child). The
first round only compiles kernels (``--warm``, not recorded). Also records whether
each configuration's last PNG frame equals the first configuration's, byte for byte
(the converged image). Writes ``OUT_DIR/frames.csv``, ``OUT_DIR/runs.csv`` and a
text summary ``OUT_DIR/summary.txt``.

    python scripts/bench_walk_cli.py --tree main=/tmp/main_src --tree branch=. \\
        --config branch:nocap=--decode-budget=0 --vpk ch2=o.vpk --rounds 3
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def run(tree: str, vpk: str, out: Path, orbit: int, extra: list[str], cache: str) -> dict:
    shutil.rmtree(out, ignore_errors=True)
    out.parent.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, PYTHONPATH=tree, VOLPACK_CACHE_DIR=cache)
    cmd = [sys.executable, "-m", "volpack", "walk", vpk, str(out) + "/", "--orbit", str(orbit),
           "--json", *extra]  # fmt: skip
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    # run from the output's folder: "-m volpack" from a source tree would import that tree
    err = tempfile.TemporaryFile("w+")  # not a pipe: nobody reads it while polling
    p = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=err, text=True,
                         cwd=out.parent)  # fmt: skip
    # when frame 0's PNG appears, seen from here (any tree: "since start" of a user)
    first_png = None
    while first_png is None and p.poll() is None:
        if out.is_dir() and any(out.iterdir()):
            first_png = time.perf_counter() - t0
        else:
            time.sleep(0.005)
    stdout, _ = p.communicate()
    err.seek(0)
    stderr = err.read()
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise SystemExit(f"{cmd} failed: {stderr[-2000:]}")
    rep = json.loads(stdout)
    last = sorted(out.glob("*.png"))[-1].read_bytes()
    return {"report": rep, "wall": wall, "user": after.ru_utime - before.ru_utime,
            "sys": after.ru_stime - before.ru_stime, "last_png": last,
            "first_png": first_png}  # fmt: skip


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tree", action="append", required=True, help="NAME=PYTHONPATH")
    ap.add_argument("--config", action="append", default=[],
                    help="TREE:NAME=OPT[,OPT...]: another run of TREE with options")  # fmt: skip
    ap.add_argument("--vpk", action="append", required=True, help="NAME=PATH of an octree")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--orbit", type=int, default=12)
    ap.add_argument("--cache", default=os.environ.get("VOLPACK_CACHE_DIR", "/tmp/volpack-cache"))
    ap.add_argument("--work", type=Path, default=Path("/tmp/bench_walk_cli"))
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "render" / "walk12")
    args = ap.parse_args(argv)
    trees = dict(t.split("=", 1) for t in args.tree)
    configs = [(n, trees[n], []) for n in trees]
    for c in args.config:
        head, opts = c.split("=", 1)
        tname, cname = head.split(":", 1)
        configs.append((cname, trees[tname], opts.split(",")))
    vpks = dict(v.split("=", 1) for v in args.vpk)
    args.out.mkdir(parents=True, exist_ok=True)
    frames, runs, lasts = [], [], {}
    for rnd in range(args.rounds + 1):  # round 0 compiles
        for vname, vpk in vpks.items():
            for cname, tree, extra in configs:
                r = run(tree, vpk, args.work / f"{vname}_{cname}", args.orbit, extra, args.cache)
                load = os.getloadavg()[0]
                print(f"round {rnd} {vname} {cname}: wall {r['wall']:.2f} user {r['user']:.2f}"
                      f" load {load:.1f}", flush=True)  # fmt: skip
                if rnd == 0:
                    continue
                lasts.setdefault(vname, {})[cname] = r["last_png"]
                rep = r["report"]
                runs.append({"round": rnd, "volume": vname, "config": cname, "wall_s": r["wall"],
                             "user_s": r["user"], "sys_s": r["sys"], "load": load,
                             "decode_budget": rep.get("decode_budget", ""),
                             "first_png_s": r["first_png"]})  # fmt: skip
                for f in rep["per_frame"]:
                    frames.append({"round": rnd, "volume": vname, "config": cname,
                                   "frame": f["frame"], "nodes": f["nodes"],
                                   "decoded": f["decoded"], "held": f.get("held", ""),
                                   "select_ms": 1000 * f["select_s"],
                                   "decode_ms": 1000 * f["decode_s"],
                                   "render_ms": 1000 * f["render_s"],
                                   "cpu_ms": 1000 * sum(f["cpu_s"]) if "cpu_s" in f else "",
                                   # seconds since the process started (walk --json's
                                   # finished_at; trees before walk18 do not report it)
                                   "finished_ms": 1000 * f["finished_at"]
                                   if f.get("finished_at") is not None else ""})  # fmt: skip
    for name, rows in (("frames", frames), ("runs", runs)):
        with open(args.out / f"{name}.csv", "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    lines = []
    for vname in vpks:
        first = configs[0][0]
        for cname, _, extra in configs:
            fr = [f for f in frames if f["volume"] == vname and f["config"] == cname]
            ru = [r for r in runs if r["volume"] == vname and r["config"] == cname]
            tot = {k: [f[k] for f in fr if f["frame"] == 0] for k in ("select_ms", "decode_ms", "render_ms")}
            f0 = [sum(x) for x in zip(*tot.values())]
            cpu0 = [f["cpu_ms"] for f in fr if f["frame"] == 0 and f["cpu_ms"] != ""]
            since = [f["finished_ms"] for f in fr if f["frame"] == 0 and f["finished_ms"] != ""]
            later = [f["select_ms"] + f["decode_ms"] + f["render_ms"] for f in fr if f["frame"] > 0]
            same = lasts[vname][cname] == lasts[vname][first]
            lines.append(
                f"{vname} {cname} {' '.join(extra)}: frame 0 "
                + ", ".join(f"{x:.0f}" for x in f0) + " ms (select "
                + "/".join(f"{x:.0f}" for x in tot["select_ms"]) + ", decode "
                + "/".join(f"{x:.0f}" for x in tot["decode_ms"]) + ", render "
                + "/".join(f"{x:.0f}" for x in tot["render_ms"]) + "); frame 0 CPU "
                + (", ".join(f"{x:.0f}" for x in cpu0) or "n/a") + " ms (mean "
                + (f"{statistics.mean(cpu0):.0f}" if cpu0 else "n/a") + "); frame 0 done "
                + (", ".join(f"{x:.0f}" for x in since) or "n/a") + " ms since start, its PNG seen "
                + ", ".join(f"{1000 * r['first_png_s']:.0f}" for r in ru if r["first_png_s"])
                + " ms after spawn; later frames "
                f"{min(later):.0f}-{max(later):.0f} ms (median {statistics.median(later):.0f},"
                f" {sum(x > 1000 for x in later)} of {len(later)} over 1 s); process wall "
                + "/".join(f"{r['wall_s']:.1f}" for r in ru) + " s, user "
                + "/".join(f"{r['user_s']:.1f}" for r in ru) + " s; last frame "
                + ("equal to" if same else "DIFFERENT from") + f" {first}'s"
            )  # fmt: skip
    (args.out / "summary.txt").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
