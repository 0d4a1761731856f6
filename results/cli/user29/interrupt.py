"""Ctrl-C during a command on a big volume: start ``volpack ARGS`` in a copy of the data
folder, send SIGINT after DELAY seconds, and report the exit code, the stderr lines,
how long it took to stop, and every file the command left (new names in the folder).

Run from the worktree: PYTHONPATH=. python results/cli/user29/interrupt.py DATA_DIR
DELAY NAME [NAME ...], NAME among RUNS.
"""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

RUNS = {
    "compress": ["compress", "ct512.npy", "int.vpk"],
    "convert_h5": ["convert", "ct512.npy", "int.h5:/data"],
    "convert_niigz": ["convert", "ct512.npy", "int.nii.gz"],
    "convert_zarr": ["convert", "ct512.npy", "int.zarr"],
    "build": ["compress", "ct512.npy", "int_oct.vpk", "--octree"],
    "batch": ["batch", "ct512.npy", "field384.npy", "intb/"],
    "compress_w2": ["compress", "ct512.npy", "int.vpk", "--workers", "2"],
    "build_w2": ["compress", "ct512.npy", "int_oct.vpk", "--octree", "--workers", "2"],
    "batch_j2": ["batch", "ct512.npy", "field384.npy", "intb/", "-j", "2"],
}


def listing(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


def one(data: Path, delay: float, args: list[str]) -> dict:
    before = listing(data)
    p = subprocess.Popen(
        [sys.executable, "-m", "volpack", *args], cwd=data,
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )  # fmt: skip
    time.sleep(delay)
    t = time.perf_counter()
    p.send_signal(signal.SIGINT)
    err = p.communicate(timeout=600)[1].decode(errors="replace")
    return {
        "exit": p.returncode,
        "stop_s": round(time.perf_counter() - t, 2),
        "stderr": err.strip().splitlines(),
        "left": sorted(p.split("/")[0] for p in listing(data) - before)[:1] or [],
    }


if __name__ == "__main__":
    os.environ.setdefault("PYTHONDONTWRITEBYTECODE", "1")
    data, delay = Path(sys.argv[1]), float(sys.argv[2])
    for name in sys.argv[3:]:
        print(name, delay, one(data, delay, RUNS[name]), flush=True)
