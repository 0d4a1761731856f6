"""The normal-code kernel of two source trees on the workload of a walk's first frame.

For each tree, in its own process (``PYTHONPATH`` = the tree), in turn round after
round: runs ``volpack walk T.vpk OUT/ --orbit 1`` in the process and records the grid
and the chunks whose codes its first frame computes (``NormalCodes.ensure``), then
times that tree's ``normals._normals_kernel`` over those chunks on one thread (least
CPU of ``--repeat`` calls into an array already written once, so no page faults) and
hashes the codes. The codes must hash alike in every tree. Appends CSV rows to
``--out``.

    python scripts/bench_normal_codes.py o.vpk --trees /tmp/main_src . --rounds 3
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def child(vpk: str, repeat: int) -> dict:
    import numpy as np

    from volpack.cli import main as cli
    from volpack.render import normals

    seen: dict = {}
    ensure = normals.NormalCodes.ensure

    def record(self, visible, brick, reach, workers=1):
        if not seen:
            need = np.zeros(self.done.shape, np.bool_)
            normals._mark_chunks(np.ascontiguousarray(visible), int(brick),
                                 int(np.ceil(reach)) + 1, need)  # fmt: skip
            seen.update(vol=self.vol, inv2=self.inv2, todo=np.argwhere(need & ~self.done))
        return ensure(self, visible, brick, reach, workers)

    normals.NormalCodes.ensure = record
    with contextlib.redirect_stdout(io.StringIO()):
        cli(["walk", vpk, tempfile.mkdtemp() + "/", "--orbit", "1"], standalone_mode=False)
    vol, inv2, todo = seen["vol"], seen["inv2"], seen["todo"].astype(np.int64)
    # this tree's unit of work: runs of chunks along x, or (main's kernel) single chunks
    work = normals.chunk_runs(todo) if hasattr(normals, "chunk_runs") else todo
    work = np.ascontiguousarray(work)
    out = np.zeros(vol.shape, np.uint16)
    best = float("inf")
    for _ in range(repeat + 1):  # the first call writes the pages
        c = time.process_time()
        normals._normals_kernel(vol, work, inv2, out)
        best = min(best, time.process_time() - c)
    return {"chunks": len(todo), "voxels": len(todo) * normals.CHUNK**3, "cpu_ms": 1e3 * best,
            "sha": hashlib.sha256(out.tobytes()).hexdigest()[:16]}  # fmt: skip


def alternate(runs, rounds: int) -> list[dict]:
    """Each ``(fields, argv, env)`` of ``runs`` as a child process (``argv`` after the
    interpreter), in turn, round after round; a child prints one JSON line. One row a
    child: the round, ``fields``, the child's JSON and the load average after it."""
    rows = []
    for rnd in range(rounds):
        for fields, argv, env in runs:
            p = subprocess.run([sys.executable, *argv], env=env, cwd=tempfile.gettempdir(),
                               capture_output=True, text=True, check=True)  # fmt: skip
            rows.append({"round": rnd, **fields, **json.loads(p.stdout.strip().splitlines()[-1]),
                         "load": round(os.getloadavg()[0], 1)})  # fmt: skip
            print(json.dumps(rows[-1]), flush=True)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("vpk")
    ap.add_argument("--trees", nargs="+", required=True)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        print(json.dumps(child(args.vpk, args.repeat)))
        return 0
    runs = [({"tree": tree, "vpk": Path(args.vpk).name},
             [__file__, args.vpk, "--trees", tree, "--child", "--repeat", str(args.repeat)],
             dict(os.environ, PYTHONPATH=tree)) for tree in args.trees]  # fmt: skip
    rows = alternate(runs, args.rounds)
    for r in rows:
        r["ns_per_voxel"] = 1e6 * r["cpu_ms"] / r["voxels"]
    print("codes alike in every tree:", len({r["sha"] for r in rows}) == 1)
    if args.out:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from bench_workers import append_csv

        append_csv(rows, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
