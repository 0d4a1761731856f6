"""A fixed-seed slice of scripts/fuzz.py: damaged streams of every kind through every
decode path end in a one-line error or a decode, never a traceback, signal or hang."""

from __future__ import annotations

import csv
import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent


# In the slow set (25 s of mutants: more kinds now share them): the fuzzer compiles once (every path run in its parent) before any
# mutant runs, and --seconds caps only the mutant phase, so an empty kernel cache makes
# the test longer but never runs fewer mutants for it. The per-run limit is generous
# because a header mutant may name a dtype whose kernel nobody compiled yet.
@pytest.mark.slow  # 25 s of mutants on both cores, beside compiling every path
@pytest.mark.skipif(not hasattr(os, "fork"), reason="the fuzzer forks its runs")
def test_fixed_seed_mutants_give_no_failures(tmp_path):
    r = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "fuzz.py"), "--count", "240", "--seconds",
         "25", "--time-limit", "120", "--seed", "1", "--workers", "2", "--out", str(tmp_path)],
        capture_output=True, text=True, timeout=900, check=False,
    )  # fmt: skip
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    with open(tmp_path / "summary.csv") as f:
        rows = list(csv.DictReader(f))
    assert sum(int(row["mutants"]) for row in rows) >= 60  # a quarter, on a busy machine
    for row in rows:
        for outcome in ("internal", "signal", "timeout", "usage", "other"):
            assert row[outcome] == "0", row
