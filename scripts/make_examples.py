"""Regenerate the example and golden files kept in the repository.

Each example is one function ``make_<name>(folder) -> path`` registered in ``EXAMPLES``;
``main()`` runs them all (or those named on the command line). Golden files are frozen:
later format versions must still decode them, so regenerate one only when its format
version changes, and then under a new name.

    python scripts/make_examples.py                  # every example into tests/golden/
    python scripts/make_examples.py container --out /tmp/x
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = ROOT / "tests" / "golden"

# -- the container example: tests/golden/tiny-v1.vpk ---------------------------------

CONTAINER_NAME = "tiny-v1.vpk"
CONTAINER_HEADER = {"kind": "test", "note": "golden vpk-1 container", "shape": [2, 3]}
# (t, node, payload, error)
CONTAINER_CHUNKS = [
    (0, 0, b"alpha", 0.0),
    (0, 1, b"", 0.25),
    (1, 7, bytes(range(16)), 1.5),
]
CONTAINER_SUMMARY = {"chunks": 3, "payload_nbytes": 21, "max_error": 1.5}


def write_container_example(target) -> None:
    """Write the tiny container to ``target`` (a path or a binary file)."""
    from volpack.container import Writer

    with Writer(target, CONTAINER_HEADER, force=True) as w:
        for t, node, payload, error in CONTAINER_CHUNKS:
            w.write(t, node, payload, error)
        w.close(summary=CONTAINER_SUMMARY)


def make_container(folder: Path) -> Path:
    path = folder / CONTAINER_NAME
    write_container_example(path)
    return path


EXAMPLES: dict[str, Callable[[Path], Path]] = {
    "container": make_container,
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "names", nargs="*", help=f"examples to make (default all: {sorted(EXAMPLES)})"
    )
    parser.add_argument("--out", type=Path, default=GOLDEN, help="output folder")
    args = parser.parse_args(argv)
    unknown = [n for n in args.names if n not in EXAMPLES]
    if unknown:
        parser.error(f"unknown examples {unknown}; choose from {sorted(EXAMPLES)}")
    os.makedirs(args.out, exist_ok=True)
    for name in args.names or sorted(EXAMPLES):
        print(EXAMPLES[name](args.out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
