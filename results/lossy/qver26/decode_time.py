"""qver26: decode time of the same cell's files (v6 = main's encoder, v7, v8, vA = the
branch), one process, interleaved, best of N rounds, one worker; prints ms and the
ratio to the first version named."""
import sys
import time

from volpack import api

rounds = int(sys.argv[1])
versions = sys.argv[2].split(",")  # e.g. 6,7,8 or 6,A
print("cell,version,bytes,best_ms,over_first")
for stem in sys.argv[3:]:  # e.g. /tmp/qver26/files/cam_t-1e-05
    blobs = {v: open(f"{stem}-v{v}.vpk", "rb").read() for v in versions}
    best = {v: float("inf") for v in blobs}
    for v, b in blobs.items():  # warm (compiles)
        api.decompress_array(b, workers=1)
    for _ in range(rounds):
        for v, b in blobs.items():
            t = time.perf_counter()
            api.decompress_array(b, workers=1)
            best[v] = min(best[v], time.perf_counter() - t)
    name = stem.rsplit("/", 1)[-1]
    for v in blobs:
        print(f"{name},{v},{len(blobs[v])},{best[v] * 1e3:.2f},{best[v] / best[versions[0]]:.3f}", flush=True)
