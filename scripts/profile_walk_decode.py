"""The chunk decoding of a walk's first frame on its own: 1 against 2 worker threads.

Runs ``volpack walk T.vpk OUT/ --orbit 1`` in this process to learn the chunks its
first frame prefetches, then, round after round, opens the octree afresh, decodes the
coarse level the walk decodes before its first frame (``lod.coarse_level``) and times
``Octree.prefetch`` of those chunks with 1 and with 2 workers: wall, process CPU, and
per part of a chunk's decoding (summed over the threads, from each thread's
``/proc/self/task/TID/schedstat``): CPU, run-queue wait (runnable, no core free: the
shared machine) and the rest of the wall, "blocked" (waiting for the GIL or a lock).
The parts: ``arith`` the entropy decoder (its numba kernel releases the GIL),
``dwt`` the inverse lifting, ``energy`` the details' energy check (numpy), ``fused``
the one kernel call that does all three for an ``arith`` tree since walk15
(``octree.chunk.decode_chunk``; the three others are then 0), ``lift_up`` a chunk's
whole decoding. Prints one line per run.

    python scripts/profile_walk_decode.py o.vpk --rounds 3
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import io
import tempfile
import threading
import time


def schedstat() -> tuple[float, float]:
    """(CPU s, run-queue wait s) of the calling thread."""
    with open(f"/proc/self/task/{threading.get_native_id()}/schedstat") as f:
        cpu, wait, _ = f.read().split()
    return int(cpu) / 1e9, int(wait) / 1e9


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("vpk")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args(argv)

    from volpack.cli import main as cli
    from volpack.entropy import arith
    from volpack.octree import chunk
    from volpack.octree import reader
    from volpack.render import lod
    from volpack.wavelet import dwt3

    seen: dict = {}
    prefetch = reader.Octree.prefetch

    def record(self, chunks, workers=1):
        seen.setdefault("chunks", set(chunks))
        return prefetch(self, chunks, workers)

    reader.Octree.prefetch = record
    with contextlib.redirect_stdout(io.StringIO()):
        cli(["walk", args.vpk, tempfile.mkdtemp() + "/", "--orbit", "1"], standalone_mode=False)
    reader.Octree.prefetch = prefetch
    parts: dict = collections.defaultdict(float)

    def timed(owner, name, label):
        fn = getattr(owner, name)

        def wrapper(*a, **k):
            c0, q0 = schedstat()
            t0 = time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                c1, q1 = schedstat()
                dt = time.perf_counter() - t0
                parts[label, "cpu"] += c1 - c0
                parts[label, "wait"] += q1 - q0
                parts[label, "blocked"] += dt - (c1 - c0) - (q1 - q0)

        setattr(owner, name, wrapper)

    timed(arith, "decode", "arith")
    timed(dwt3, "inverse", "dwt")
    timed(reader.Octree, "_energy_matches", "energy")
    timed(reader.Octree, "_lift_up", "lift_up")
    timed(chunk, "decode_chunk", "fused")
    for rnd in range(args.rounds):
        for workers in (1, 2):
            tree = reader.Octree(args.vpk)
            lod.coarse_level(tree)
            todo = [c for c in seen["chunks"] if not tree.is_cached(*c)]
            parts.clear()
            w0, c0 = time.perf_counter(), time.process_time()
            tree.prefetch(seen["chunks"], workers)
            w1, c1 = time.perf_counter(), time.process_time()
            detail = "; ".join(
                f"{p} CPU {1e3 * parts[p, 'cpu']:.0f} wait {1e3 * parts[p, 'wait']:.0f}"
                f" blocked {1e3 * parts[p, 'blocked']:.0f}"
                for p in ("lift_up", "fused", "arith", "dwt", "energy")
            )  # fmt: skip
            print(f"round {rnd} workers {workers}: {len(todo)} chunks, wall {1e3 * (w1 - w0):.0f}"
                  f" ms, CPU {1e3 * (c1 - c0):.0f} ms; {detail}", flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
