"""Where the float lossless encode's time goes: cProfile of ``api.compress_array(a,
workers=1)`` per volume (kernels warmed first), the cumulative CPU of each tool's entry
point, and which tool each brick took.

    PYTHONPATH=. python results/lossless/flen31/tools_profile.py OUT.txt NAME_OR_NPY...
"""

from __future__ import annotations

import cProfile
import pstats
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
from datasets import load  # noqa: E402

from volpack import api  # noqa: E402

# (file suffix, function) of the tools' entry points
TOOLS = [
    ("codec.py", "encode", "zstd (levels 9 and 19, by ZstdCodec.encode)"),
    ("floatcode.py", "encode", "split floats (predict-float)"),
    ("predict.py", "encode", "version-1 predictor (palette ranks; lattice fields)"),
    ("labels.py", "encode", "labels"),
    ("floatpredict.py", "encode_best_lorenzo", "Lorenzo, best of 4"),
    ("floatpredict.py", "encode_lorenzo", "  one Lorenzo"),
    ("floatpredict.py", "find_lattices", "lattice search"),
    ("lossless.py", "_encode_float", "_encode_float (all mode-5 tools)"),
    ("floatfit.py", "encode_best", "fit: encode_best"),
    ("floatfit.py", "fit", "  fit: least squares"),
    ("floatfit.py", "encode", "  fit: one stream"),
    ("floatmix.py", "copy_offsets", "blend: copy offsets"),
    ("floatmix.py", "fill_value", "blend: fill value"),
    ("floatmix.py", "encode", "blend: stream"),
    ("lossless.py", "_encode_predict", "_encode_predict (mode 4)"),
    ("lossless.py", "encode", "LosslessCodec.encode (all, nested lattice calls too)"),
]


def volume(spec: str) -> np.ndarray:
    if spec.endswith(".npy"):
        return np.load(spec, mmap_mode="r")[...]
    if spec == "field384_c128":
        a = np.load("/tmp/flen31/big/field384.npy", mmap_mode="r")
        return np.ascontiguousarray(a[128:256, 128:256, 128:256])
    return np.asarray(load(spec)[0])


def main() -> None:
    out, specs = sys.argv[1], sys.argv[2:]
    api.compress_array(volume("ct_skull_float")[:32, :32, :32], workers=1)  # compile
    lines = []
    for spec in specs:
        a = volume(spec)
        pr = cProfile.Profile(timer=time.process_time)
        t = time.process_time()
        pr.enable()
        blob = api.compress_array(a, workers=1)
        pr.disable()
        cpu = time.process_time() - t
        st = pstats.Stats(pr).stats
        lines.append(f"## {spec} {a.shape} {a.dtype}: {cpu:.2f} CPU s, {len(blob)} bytes")
        for suffix, name, label in TOOLS:
            rows = [(v[0], v[3]) for k, v in st.items() if k[0].endswith(suffix) and k[2] == name]
            if rows:
                n = sum(r[0] for r in rows)
                c = sum(r[1] for r in rows)
                lines.append(f"  {label:55s} {c:7.2f} s  {100 * c / cpu:5.1f} %  calls {n}")
        lines.append(f"  tools: {api.info(blob)['summary']['tools']}")
        print("\n".join(lines[-(len(TOOLS) + 2) :]), flush=True)
    Path(out).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
