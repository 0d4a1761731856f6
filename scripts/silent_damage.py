"""How often payload damage that passes every checksum decodes without an error to other
voxels: the fuzzer's ``payload`` mutants (``scripts/fuzz.py``) of one stream, decoded in
this process by ``api.decompress`` (no fork, no limits: for streams the fuzzer has
already shown to fail cleanly), so a few hundred take about a minute.

    python scripts/silent_damage.py octree-bounded-u8 300
    python scripts/silent_damage.py wavelet-haar-huffman-dfs-u8 400 --seed x

Prints the outcome counts, the silent rate, and the most frequent error messages.
"""

from __future__ import annotations

import argparse
import collections
import pathlib
import random
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import fuzz  # noqa: E402  (the mutations are the fuzzer's)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("stream", help="a golden example's name (formats/examples) or a .vpk path")
    ap.add_argument("count", type=int, nargs="?", default=300)
    ap.add_argument("--seed", default="x", help="mutant i uses random.Random(f'{seed}:{i}')")
    args = ap.parse_args()

    import numpy as np

    from volpack import api
    from volpack.errors import FormatError

    path = pathlib.Path(args.stream)
    if not path.exists():
        path = fuzz.EXAMPLES / f"{args.stream.removesuffix('.vpk')}.vpk"
    seed = path.read_bytes()
    parsed = fuzz.parse(seed)

    def arrays(decoded) -> list:
        """The decoded voxels, or a mesh's points, tetrahedra and fields."""
        if hasattr(decoded, "tets"):
            fields = [*decoded.point_data.items(), *decoded.cell_data.items()]
            return [decoded.points, decoded.tets, *(np.asarray(v) for _, v in sorted(fields))]
        return [np.asarray(decoded.data)]

    def same(a: list, b: list) -> bool:
        return len(a) == len(b) and all(
            x.shape == y.shape and np.array_equal(x, y, equal_nan=x.dtype.kind == "f")
            for x, y in zip(a, b)
        )

    ref = arrays(api.decompress(seed))
    counts: collections.Counter = collections.Counter()
    messages: collections.Counter = collections.Counter()
    for i in range(args.count):
        blob = fuzz.mutant(random.Random(f"{args.seed}:{i}"), "payload", seed, parsed)
        try:
            out = arrays(api.decompress(blob))
        except FormatError as e:
            counts["error"] += 1
            messages[str(e)[:100]] += 1
            continue
        counts["same" if same(out, ref) else "silent"] += 1
    n = sum(counts.values())
    print(f"{path.name}: {n} payload mutants: {dict(counts)}; silent "
          f"{counts['silent']}/{n} = {100 * counts['silent'] / max(n, 1):.1f} %")  # fmt: skip
    for m, k in messages.most_common(6):
        print(f"  {k} x {m}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
