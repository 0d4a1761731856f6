"""volpack as a zarr codec: store a real volume as a chunked zarr array on disk and compare
volpack's wavelet coding with zarr's own compressors.

Every row writes the same volume to a fresh zarr v3 array (``zarr_format=3``) with cubic
chunks (64^3 by default) on local disk and reads it back:

* ``volpack-arith`` / ``volpack-huffman``: ``volpack.numcodecs.VolpackCodec`` (lossless
  5/3 wavelet with the arithmetic or the Huffman coder) as the array-to-bytes
  ``serializer``, so it receives each chunk as an array, with no further compressor.
  zarr 3 has no public wrapper for a third-party numcodecs codec, so the script
  subclasses the private ``zarr.codecs.numcodecs._codecs._NumcodecsArrayBytesCodec``
  (the base of zarr's own ``PCodec``/``ZFPY`` wrappers) and registers it;
* ``volpack-arith-v2``: the same codec as the ``compressor`` of a ``zarr_format=2``
  array, the path that needs nothing but ``import volpack.numcodecs``;
* ``zarr-default``: ``zarr.create_array``'s defaults (the codecs zarr picked are written
  to the table: ``BytesCodec`` + ``ZstdCodec(level=0)`` in zarr 3.1);
* ``blosc-zstd-bitshuffle``: ``BytesCodec`` + ``BloscCodec(cname="zstd", clevel=5,
  shuffle="bitshuffle")``.

Measured: store size (the sum of the sizes of every file in the store, metadata
included), ratio (raw bytes / store size), write MB/s (create the array and assign the
whole volume, into an emptied folder) and read MB/s (open the array and read it all),
MB = 1e6 raw bytes, best of ``--repeat`` runs. Reads come from the OS page cache. Every
row checks that the array reads back exactly.

    python scripts/fetch_data.py ct_head          # once
    python scripts/bench_zarr.py                   # head CT, 64^3 chunks, best of 3

Writes ``zarr.csv`` and ``table.md`` to ``--out`` (default ``results/zarr``).
"""

from __future__ import annotations

import argparse
import csv
import datetime
import os
import platform
import shutil
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def volpack_serializer_class() -> type:
    """``VolpackCodec`` as a zarr 3 array-to-bytes codec, registered with zarr."""
    import volpack.numcodecs
    import volpack.zarr3

    return volpack.zarr3.VolpackWavelet


@dataclass
class Method:
    name: str
    zarr_format: int
    create_kwargs: Callable[[], dict]


def methods() -> list[Method]:
    from zarr.codecs import BloscCodec

    from volpack.numcodecs import VolpackCodec

    wrapper = volpack_serializer_class()

    def volpack3(coder: str) -> Callable[[], dict]:
        return lambda: {
            "serializer": wrapper(**VolpackCodec(coder=coder).get_config()),
            "compressors": None,
        }

    return [
        Method("volpack-arith", 3, volpack3("arith")),
        Method("volpack-huffman", 3, volpack3("huffman")),
        Method("volpack-arith-v2", 2, lambda: {"compressors": [VolpackCodec()]}),
        Method("zarr-default", 3, lambda: {}),
        Method(
            "blosc-zstd-bitshuffle",
            3,
            lambda: {"compressors": [BloscCodec(cname="zstd", clevel=5, shuffle="bitshuffle")]},
        ),
    ]


def store_nbytes(path: Path) -> tuple[int, int]:
    """Total size and number of the files under ``path``."""
    total = files = 0
    for dirpath, _, names in os.walk(path):
        for n in names:
            total += os.path.getsize(os.path.join(dirpath, n))
            files += 1
    return total, files


def describe_codecs(z) -> str:
    md = z.metadata
    if md.zarr_format == 2:
        return f"v2 compressor={md.compressor!r}"
    return " + ".join(repr(c) for c in md.codecs)


def run_method(m: Method, a: np.ndarray, chunks: tuple[int, ...], work: Path, repeat: int) -> dict:
    import zarr

    path = work / f"{m.name}.zarr"
    write_s, read_s = [], []
    for _ in range(repeat):
        shutil.rmtree(path, ignore_errors=True)
        kwargs = m.create_kwargs()
        t0 = time.perf_counter()
        z = zarr.create_array(
            store=path,
            shape=a.shape,
            chunks=chunks,
            dtype=a.dtype,
            zarr_format=m.zarr_format,
            fill_value=0,
            **kwargs,
        )
        z[:] = a
        write_s.append(time.perf_counter() - t0)
    for _ in range(repeat):
        t0 = time.perf_counter()
        back = zarr.open_array(path, mode="r")[:]
        read_s.append(time.perf_counter() - t0)
        if not (back.dtype == a.dtype and np.array_equal(back, a)):
            raise AssertionError(f"{m.name}: the array read back differs from the volume")
    nbytes, files = store_nbytes(path)
    codecs = describe_codecs(zarr.open_array(path, mode="r"))
    shutil.rmtree(path, ignore_errors=True)
    mb = a.nbytes / 1e6
    return {
        "method": m.name,
        "zarr_format": m.zarr_format,
        "codecs": codecs,
        "chunks": "x".join(map(str, chunks)),
        "raw_nbytes": int(a.nbytes),
        "store_nbytes": nbytes,
        "files": files,
        "ratio": a.nbytes / nbytes,
        "write_mb_s": mb / min(write_s),
        "read_mb_s": mb / min(read_s),
        "exact": True,
    }


def warm_up() -> None:
    """Compile (or load from numba's cache) the kernels before anything is timed."""
    from volpack.numcodecs import VolpackCodec

    a = np.arange(4096, dtype=np.int16).reshape(16, 16, 16) % 97
    for coder in ("arith", "huffman"):
        c = VolpackCodec(coder=coder)
        assert np.array_equal(c.decode(c.encode(a)), a)


def write_table(rows: list[dict], out: Path, info: dict) -> None:
    lines = [
        "# volpack in zarr: store size and speed",
        "",
        f"Volume: {info['dataset']} {info['shape']} {info['dtype']} "
        f"({info['raw_mb']:.1f} MB raw), {info['description']}.",
        f"Chunks {info['chunks']} ({info['nchunks']} chunks), local disk, "
        f"best of {info['repeat']} runs; MB = 1e6 raw bytes. "
        f"zarr {info['zarr']}, numcodecs {info['numcodecs']}, numpy {info['numpy']}, "
        f"Python {info['python']}, {info['cpus']} CPUs; {info['date']}.",
        "",
        "| method | zarr format | store bytes | files | ratio | write MB/s | read MB/s |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r['method']} | {r['zarr_format']} | {r['store_nbytes']:,} | {r['files']} "
            f"| {r['ratio']:.3f} | {r['write_mb_s']:.1f} | {r['read_mb_s']:.1f} |"
        )
    lines += ["", "Codecs as recorded in each array's metadata:", ""]
    lines += [f"- {r['method']}: `{r['codecs']}`" for r in rows]
    lines.append("")
    (out / "table.md").write_text("\n".join(lines))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--dataset", default="ct_head")
    p.add_argument("--chunk", type=int, default=64, help="cubic chunk edge (default 64)")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--out", type=Path, default=ROOT / "results" / "zarr")
    p.add_argument("--tmp", type=Path, default=None, help="folder for the stores")
    args = p.parse_args(argv)

    import numcodecs
    import zarr

    a, _, description = datasets.load(args.dataset)
    chunks = (args.chunk,) * a.ndim
    warm_up()
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    with warnings.catch_warnings():
        # zarr warns that numcodecs codecs in v3 arrays are outside the v3 specification.
        warnings.filterwarnings("ignore", message="Numcodecs codecs are not in the Zarr")
        with tempfile.TemporaryDirectory(dir=args.tmp, prefix="bench_zarr_") as work:
            for m in methods():
                r = run_method(m, a, chunks, Path(work), args.repeat)
                rows.append(r)
                print(
                    f"{r['method']:>22}  ratio {r['ratio']:6.3f}  store {r['store_nbytes']:>10,} B"
                    f"  write {r['write_mb_s']:7.1f} MB/s  read {r['read_mb_s']:7.1f} MB/s",
                    flush=True,
                )
    with open(args.out / "zarr.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    info = {
        "dataset": args.dataset,
        "shape": "x".join(map(str, a.shape)),
        "dtype": str(a.dtype),
        "raw_mb": a.nbytes / 1e6,
        "description": description,
        "chunks": "x".join(map(str, chunks)),
        "nchunks": int(np.prod([-(-n // c) for n, c in zip(a.shape, chunks)])),
        "repeat": args.repeat,
        "zarr": zarr.__version__,
        "numcodecs": numcodecs.__version__,
        "numpy": np.__version__,
        "python": platform.python_version(),
        "cpus": os.cpu_count(),
        "date": datetime.date.today().isoformat(),
    }
    write_table(rows, args.out, info)
    print(f"wrote {args.out / 'zarr.csv'} and {args.out / 'table.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
