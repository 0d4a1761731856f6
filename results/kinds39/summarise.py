"""Tables, CSV and a chart from trial.py's JSON lines: kinds37's summariser (the same
JSON lines, the same tables) with this trial's held-out set and makers.

    python results/kinds39/summarise.py OUT.csv CHART.png RUN.jsonl [RUN.jsonl ...]
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

HERE = Path(__file__).resolve().parent


def _load(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


if __name__ == "__main__":
    ours = _load("kinds39_make", HERE / "make.py")
    shared = _load("kinds37_summarise", HERE.parent / "kinds37" / "summarise.py")
    shared.main("kinds39", ours.HELD_OUT, ours.MAKERS)
