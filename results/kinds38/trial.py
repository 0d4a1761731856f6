"""The trial, as a user runs it: one `volpack compare` process per cell.

    PYTHONPATH=. python results/kinds38/trial.py DIR OUT.jsonl [--held] [--fill] [NAME ...]

Integer volumes: `python -m volpack -q compare F.npy --peers --jpegxl-efforts 7,9 --json`.
Float fields: `python -m volpack -q compare F.npy --rel-error E --peers --json` at
E = 1e-2, 1e-3, 1e-4. Without --held the held-out volumes are skipped; with it only they
run. Each cell's JSON (or the failing command's last stderr line) is appended to
OUT.jsonl; cells already there are not run again. With --fill, the fields with a fill
value (FILL) get `--fill-value` as a user told by volpack's warning would give it. Every bound is checked here on the
JSON's max error too (compare itself decodes and checks every voxel).
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from make import HELD_OUT, MAKERS  # noqa: E402
from trialkit import run_cell, run_trial  # noqa: E402

FILL = {"letkf_t": "-9.9999e30", "letkf_qv": "-9.9999e30"}


def main() -> None:
    args = [a for a in sys.argv[1:] if a not in ("--held", "--fill")]
    fill = "--fill" in sys.argv
    held = "--held" in sys.argv
    d, out = Path(args[0]), Path(args[1])
    names = args[2:] or [n for n in MAKERS if (n in HELD_OUT) == held]

    def cell(path: Path, rel: str | None) -> dict:
        given = fill and path.stem in FILL
        return run_cell(path, rel, extra=["--fill-value", FILL[path.stem]] if given else ())

    run_trial(d, out, names, cell)


if __name__ == "__main__":
    main()
