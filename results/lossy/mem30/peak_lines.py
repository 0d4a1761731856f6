"""What is held, by line, near the traced peak of one lossy encode: a thread polls the
traced memory every 2 ms and snapshots it each time it passes its highest by 4 MB (an
approximation of the peak's moment: allocations between two polls are missed).

    PYTHONPATH=. python results/lossy/mem30/peak_lines.py FIELD.npy [--rel 1e-3] [--top 25]
"""

import threading
import time
import tracemalloc

import numpy as np
from common import field_and_bound

from volpack import api

MB = 1e6


def main():
    a, x, e = field_and_bound(("--top", int, 25))
    warm = np.cumsum(np.random.default_rng(0).standard_normal((24, 24, 24)), axis=2)
    api.compress_array(warm.astype(np.float32), max_error=40 * a.rel)
    tracemalloc.start(12)
    best = [0, None]
    done = threading.Event()

    def poll():
        while not done.is_set():
            cur = tracemalloc.get_traced_memory()[0]
            if cur > best[0] + 4 * MB:
                best[:] = [cur, tracemalloc.take_snapshot()]
            time.sleep(0.002)

    th = threading.Thread(target=poll)
    th.start()
    api.compress_array(x, max_error=e, workers=1)
    done.set()
    th.join()
    print(
        f"traced peak {tracemalloc.get_traced_memory()[1] / MB:.1f} MB; "
        f"snapshot at {best[0] / MB:.1f} MB"
    )
    for s in best[1].statistics("traceback")[: a.top]:
        print(f"{s.size / MB:8.1f} MB")
        for fr in s.traceback.format()[-12:]:
            if "volpack" in fr and "site-packages" not in fr:
                print("        ", fr.strip())


if __name__ == "__main__":
    main()
