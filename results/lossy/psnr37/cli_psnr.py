"""volpack's own PSNR mode as a user runs it: one CLI process per (field, target).

    PYTHONPATH=. python results/lossy/psnr37/cli_psnr.py DATA_DIR OUT.jsonl [FIELD ...]

Runs ``python -m volpack -q compare DATA_DIR/FIELD.npy --psnr P --json`` at P = 40, 60, 80
(``--fill-value 1e35`` for isabel_pfill) and appends one JSON line per run: the field, the
target, the return code, stderr's last line, and the compare report (decoded and measured on
every voxel by compare itself).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

FIELDS = ["miranda_visc", "nyx_vel", "nyx_temp", "isabel_qcloud", "s3d_oh64", "s3d_temp64",
          "qmc_orb3d", "isabel_pfill", "dwi_piesno_float", "grid3d_var3"]  # fmt: skip
TARGETS = (40.0, 60.0, 80.0)
FILL = {"isabel_pfill": 1e35}


def main() -> None:
    data, out = Path(sys.argv[1]), Path(sys.argv[2])
    fields = sys.argv[3:] or FIELDS
    for name in fields:
        for p in TARGETS:
            cmd = [sys.executable, "-m", "volpack", "-q", "compare", str(data / f"{name}.npy"),
                   "--psnr", f"{p:g}", "--json"]  # fmt: skip
            if name in FILL:
                cmd += ["--fill-value", f"{FILL[name]:g}"]
            r = subprocess.run(cmd, capture_output=True, text=True)
            row = {"field": name, "target": p, "rc": r.returncode,
                   "stderr": r.stderr.strip().splitlines()[-1:] if r.stderr.strip() else []}  # fmt: skip
            try:
                row["report"] = json.loads(r.stdout)
            except ValueError:
                row["report"] = None
            rep = row["report"] or {}
            print(name, p, r.returncode, rep.get("bpv"), rep.get("psnr"),
                  (rep.get("compress") or {}).get("psnr"), row["stderr"], flush=True)  # fmt: skip
            with open(out, "a") as f:
                f.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
