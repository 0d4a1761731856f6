"""The trial, as a user runs it: one `volpack compare` process per cell (kinds38's
trial.py with JPEG-XL e10 added and this trial's makers).

    PYTHONPATH=. python results/kinds39/trial.py DIR OUT.jsonl [--held] [--no-e10] [NAME ...]

Integer volumes: `python -m volpack -q compare F.npy --peers --jpegxl-efforts 7,9,10 --json`
(`--no-e10`: 7,9). Float fields: `--rel-error E --peers --json` at E = 1e-2, 1e-3, 1e-4.
Without --held the held-out volumes are skipped; with it only they run. Each cell's JSON
(or the failing command's last stderr line) is appended to OUT.jsonl; cells already there
are not run again. compare decodes and checks every voxel against the bound.
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from make import HELD_OUT, MAKERS  # noqa: E402
from trialkit import run_cell, run_trial  # noqa: E402


def main() -> None:
    flags = {"--held", "--no-e10"}
    args = [a for a in sys.argv[1:] if a not in flags]
    held = "--held" in sys.argv
    efforts = "7,9" if "--no-e10" in sys.argv else "7,9,10"
    d, out = Path(args[0]), Path(args[1])
    names = args[2:] or [n for n in MAKERS if (n in HELD_OUT) == held]
    run_trial(d, out, names, lambda path, rel: run_cell(path, rel, efforts))


if __name__ == "__main__":
    main()
