"""A/B in one process: the 512^3 uint16 CT written as a zarr store whole (one
``array[...] = data``, the base) against by rows of chunks (``_write_slabs``, Ctrl-C
held back within a row), interleaved, best of ROUNDS.

Run: PYTHONPATH=. python results/cli/user29/zarr_ab.py DATA_DIR [ROUNDS]
"""

import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import zarr

from volpack.io.zarrstore import _write_slabs


def one(data: np.ndarray, slabs: bool) -> float:
    where = tempfile.mkdtemp(dir="/tmp")
    try:
        t = time.perf_counter()
        group = zarr.open_group(where + "/s.zarr", mode="w", zarr_format=3)
        array = group.create_array("0", shape=data.shape, chunks=(64,) * 3, dtype=data.dtype)
        if slabs:
            _write_slabs(array, data, 64)
        else:
            array[...] = data
        return time.perf_counter() - t
    finally:
        shutil.rmtree(where)


if __name__ == "__main__":
    data = np.load(Path(sys.argv[1]) / "ct512.npy")
    best = {"whole": 1e9, "slabs": 1e9}
    for _ in range(int(sys.argv[2]) if len(sys.argv) > 2 else 4):
        for name in best:
            best[name] = min(best[name], one(data, name == "slabs"))
    print({k: round(v, 2) for k, v in best.items()})
