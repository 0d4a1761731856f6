"""The trial, as a user runs it: one `volpack compare` process per cell.

    PYTHONPATH=. python results/kinds37/trial.py DIR OUT.jsonl [--held] [NAME ...]

Integer volumes: `python -m volpack -q compare F.npy --peers --jpegxl-efforts 7,9 --json`.
Float fields: `python -m volpack -q compare F.npy --rel-error E --peers --json` at
E = 1e-2, 1e-3, 1e-4. Without --held the held-out volumes are skipped; with it only they
run. Each cell's JSON (or the failing command's last stderr line) is appended to
OUT.jsonl; cells already there are not run again. Every bound is checked here on the
JSON's max error too (compare itself decodes and checks every voxel).
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from make import HELD_OUT, MAKERS  # noqa: E402
from trialkit import run_cell, run_trial  # noqa: E402


def main() -> None:
    args = [a for a in sys.argv[1:] if a != "--held"]
    held = "--held" in sys.argv
    d, out = Path(args[0]), Path(args[1])
    names = args[2:] or [n for n in MAKERS if (n in HELD_OUT) == held]
    run_trial(d, out, names, run_cell)


if __name__ == "__main__":
    main()
