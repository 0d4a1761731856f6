"""Run volpack commands on the big volumes as a user would, one process each, under
``/usr/bin/time -v``: wall, peak RSS (and its ratio to the input's voxel bytes), the
longest stretch with nothing on stderr (no bar, no notice line), the exit code, the
last stderr line. One CSV row per command.

Run from the worktree: PYTHONPATH=. python results/cli/user29/bigrun.py DATA_DIR OUT.csv
[NAME ...] (the names of RUNS to run, in order; default all). Stderr is a pipe (no
terminal), so the bars are the notices' lines every few seconds.
"""

import csv
import os
import re
import subprocess
import sys
import time
from pathlib import Path

CT, F = "ct512.npy", "field384.npy"
MB_CT, MB_F = 268.4, 226.5  # voxel MB
RUNS = {  # name -> (arguments after 'volpack', voxel MB of the volume)
    "info_ct": (["info", CT], MB_CT),
    "compress_ct": (["compress", CT, "ct.vpk", "-f"], MB_CT),
    "compress_ct_e2": (["compress", CT, "ct_e2.vpk", "--max-error", "2", "-f"], MB_CT),
    "compress_f": (["compress", F, "f.vpk", "-f"], MB_F),
    "info_ct_vpk": (["info", "ct.vpk"], MB_CT),
    "decompress_ct": (["decompress", "ct.vpk", "ct_back.npy", "-f"], MB_CT),
    "decompress_f": (["decompress", "f.vpk", "f_back.npy", "-f"], MB_F),
    "convert_ct_niigz": (["convert", CT, "ct.nii.gz", "-f"], MB_CT),
    "convert_ct_h5": (["convert", CT, "ct.h5:/data", "-f"], MB_CT),
    "convert_ct_zarr": (["convert", CT, "ct.zarr", "-f"], MB_CT),
    "convert_f_niigz": (["convert", F, "f.nii.gz", "-f"], MB_F),
    "convert_f_h5": (["convert", F, "f.h5:/data", "-f"], MB_F),
    "convert_f_zarr": (["convert", F, "f.zarr", "-f"], MB_F),
    "build_ct": (["compress", CT, "ct_oct.vpk", "--octree", "-f"], MB_CT),
    "walk_ct": (["walk", "ct_oct.vpk", "walk/", "--orbit", "4", "--budget", "1024",
                 "--tf", "ct-bone", "-f"], MB_CT),
    "render_ct": (["render", "ct.vpk", "ct.png", "--tf", "ct-bone", "-f"], MB_CT),
    "compare_ct": (["compare", CT, "ct_e2.vpk"], MB_CT),
    "compare_f": (["compare", F, "f.vpk"], MB_F),
}  # fmt: skip


def one(args: list[str], data: Path) -> dict:
    """Run ``volpack ARGS`` in ``data``; stderr lines timed as they come."""
    tv = data / ".time.txt"
    cmd = ["/usr/bin/time", "-v", "-o", str(tv), sys.executable, "-m", "volpack", *args]
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, cwd=data, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    last, gap, lines = t0, 0.0, []
    for raw in p.stderr:
        now = time.perf_counter()
        gap, last = max(gap, now - last), now
        lines.append(raw.decode(errors="replace").rstrip())
    code = p.wait()
    end = time.perf_counter()
    gap = max(gap, end - last)
    text = tv.read_text()
    rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", text).group(1))
    return {"wall_s": round(end - t0, 1), "peak_rss_mb": round(rss / 1024),
            "longest_silence_s": round(gap, 1), "exit": code,
            "stderr_lines": len(lines), "last_line": lines[-1] if lines else ""}  # fmt: skip


def main(data: Path, out: Path, names: list[str]) -> None:
    rows = []
    for name in names or list(RUNS):
        args, mb = RUNS[name]
        r = {"name": name, "command": "volpack " + " ".join(args), **one(args, data)}
        r["rss_over_volume"] = round(r["peak_rss_mb"] * 1.048576 / mb, 2)
        rows.append(r)
        print(r, flush=True)
    new = not out.exists()
    with open(out, "a", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        if new:
            w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    os.environ.setdefault("PYTHONDONTWRITEBYTECODE", "1")
    main(Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3:])
