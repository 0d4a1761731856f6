"""Helpers of the command-line tests written as a user meets volpack
(``tests/cli/test_new_user.py``, ``tests/cli/test_user29.py``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from click.testing import CliRunner

from volpack.cli import main


def run(*args):
    """``volpack ARGS`` in this process; paths may be given as Paths."""
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def _compile_notice(line: str) -> bool:
    return line.startswith("volpack: first run of this volpack") or (
        line.startswith("volpack: ") and ": compiling kernels (" in line
    )


def one_error_line(r) -> str:
    """The one line ``volpack: error: ...`` a failed command printed (asserted alone; the
    compile notices a first run on an empty kernel cache prints are not its output)."""
    lines = [ln for ln in r.stderr.splitlines() if ln.strip() and not _compile_notice(ln)]
    assert len(lines) == 1 and lines[0].startswith("volpack: error: "), r.stderr
    return lines[0]


def small_npy(folder: Path) -> Path:
    """``a.npy`` in ``folder``: a 4x5x6 uint8 ramp."""
    p = folder / "a.npy"
    np.save(p, np.arange(4 * 5 * 6, dtype=np.uint8).reshape(4, 5, 6))
    return p
