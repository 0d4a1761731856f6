"""Regenerate the example and golden files kept in the repository.

Each example is one function ``make_<name>(folder) -> path`` registered in ``EXAMPLES``;
``main()`` runs them all (or those named on the command line). Golden files are frozen:
later format versions must still decode them, so regenerate one only when its format
version changes, and then under a new name.

    python scripts/make_examples.py                  # every example into formats/examples/
    python scripts/make_examples.py container --out /tmp/x
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = ROOT / "formats" / "examples"

# -- the container examples: formats/examples/tiny-v1.vpk, tiny-v2.vpk -------------------

CONTAINER_NAME = "tiny-v1.vpk"
CONTAINER_HEADER = {"kind": "test", "note": "golden vpk-1 container", "shape": [2, 3]}
# (t, node, payload, error)
CONTAINER_CHUNKS = [
    (0, 0, b"alpha", 0.0),
    (0, 1, b"", 0.25),
    (1, 7, bytes(range(16)), 1.5),
]
CONTAINER_SUMMARY = {"chunks": 3, "payload_nbytes": 21, "max_error": 1.5}
# version 2 (formats/vpk-2.md): the same and a chunk with two-byte varints and an error
# that only float64 holds, so every error form and varint length occurs
CONTAINER_V2_NAME = "tiny-v2.vpk"
CONTAINER_V2_HEADER = {"kind": "test", "note": "golden vpk-2 container", "shape": [2, 3]}
CONTAINER_V2_CHUNKS = [*CONTAINER_CHUNKS, (2, 300, bytes(range(200)), 0.1)]
CONTAINER_V2_SUMMARY = {"chunks": 4, "payload_nbytes": 221, "max_error": 1.5}


def write_container_example(target, version: int = 1) -> None:
    """Write the tiny container of format ``version`` to ``target`` (a path or a binary
    file)."""
    from volpack.format.container import Writer

    header, chunks, summary = (
        (CONTAINER_HEADER, CONTAINER_CHUNKS, CONTAINER_SUMMARY)
        if version == 1
        else (CONTAINER_V2_HEADER, CONTAINER_V2_CHUNKS, CONTAINER_V2_SUMMARY)
    )
    with Writer(target, header, force=True, version=version) as w:
        for t, node, payload, error in chunks:
            w.write(t, node, payload, error)
        w.close(summary=summary)


def make_container(folder: Path) -> Path:
    write_container_example(folder / CONTAINER_NAME, 1)
    path = folder / CONTAINER_V2_NAME
    write_container_example(path, 2)
    return path


# -- wavelet codec examples: formats/examples/wavelet-*.vpk ------------------------------

# (file stem, source recipe, codec options); every recipe cuts the bundled MRI.
WAVELET_CASES = [
    (
        "wavelet-53-arith-dfs-u8",
        "u8",
        {"codec": "wavelet", "wavelet": "53", "coder": "arith", "order": "dfs"},
    ),
    (
        "wavelet-53-huffman-dfs-i16",
        "i16",
        {"codec": "wavelet", "wavelet": "53", "coder": "huffman", "order": "dfs"},
    ),
    (
        "wavelet-53-rle-line-u8",
        "u8",
        {"codec": "wavelet", "wavelet": "53", "coder": "rle", "order": "line"},
    ),
    (
        "wavelet-26-arith-line-i16",
        "i16",
        {"codec": "wavelet", "wavelet": "26", "coder": "arith", "order": "line"},
    ),
    (
        "wavelet-haar-huffman-dfs-u8",
        "u8",
        {"codec": "wavelet", "wavelet": "haar", "coder": "huffman", "order": "dfs"},
    ),
    (
        "wavelet-97m-arith-dfs-i16",
        "i16",
        {"codec": "wavelet", "wavelet": "97m", "coder": "arith", "order": "dfs"},
    ),
    (
        "wavelet-53-arith-dfs-labels",
        "labels",
        {"codec": "wavelet", "wavelet": "53", "coder": "arith", "order": "dfs"},
    ),
    (
        "wavelet-53-arith2-dfs-u8",
        "u8",
        {"codec": "wavelet", "wavelet": "53", "coder": "arith2", "order": "dfs"},
    ),
    (
        "wavelet-97m-arith2-line-i16",
        "i16",
        {"codec": "wavelet", "wavelet": "97m", "coder": "arith2", "order": "line"},
    ),
]
WAVELET_BRICK = 16


def wavelet_source(recipe: str):
    """The small volume a wavelet example codes: a (20, 24, 28) cut of the bundled MRI."""
    import numpy as np

    from volpack.demo import load_demo_volume

    cut = load_demo_volume().data[30:50, 40:64, 40:68]
    if recipe == "u8":
        return cut
    if recipe == "i16":
        return cut.astype(np.int16) * 37 - 3000
    if recipe == "labels":  # three tissue classes and a constant corner: modes 2 and 3
        lab = np.digitize(cut, [40, 90]).astype(np.uint8)
        lab[:16, :16, :16] = 0
        return lab
    raise ValueError(f"unknown recipe {recipe!r}")


def make_wavelet(folder: Path) -> Path:
    from volpack import api

    for stem, recipe, opts in WAVELET_CASES:
        path = folder / f"{stem}.vpk"
        api.compress(wavelet_source(recipe), str(path), brick=WAVELET_BRICK, force=True, **opts)
    return folder


# -- lossless codec examples: formats/examples/lossless-*.vpk ----------------------------

# Version 1 of the predictive stream (the files written before version 2), then version 2.
V1 = {"predict_version": 1}
V2 = {"predict_version": 2}
V3 = {"predict_version": 3}
LOSSLESS_CASES = [
    ("lossless-auto-u8", "u8-background", V1),
    ("lossless-auto-i16-palette", "i16", V1),
    ("lossless-predict-u8", "u8", {"tools": "predict", **V1}),
    ("lossless-auto-f32-special", "f32-special", V1),
    ("lossless-auto-f32-field", "f32-field", V1),
    # one 32^3 brick each: version 2 stores 136 bytes of weights, which 16^3 bricks of
    # the cut above do not repay (the encoder then keeps version 1)
    ("lossless-v2-u8-mask", "v2-u8-background", {"brick": 32, **V2}),
    ("lossless-v2-i16-palette", "v2-i16", {"brick": 32, **V2}),
    ("lossless-v2-predict-u8", "v2-u8", {"tools": "predict", "brick": 32, **V2}),
    # version 3: floats by Lorenzo prediction and on a lattice (mode 5), in 32 and 64 bits
    ("lossless-v3-f32-special", "f32-special", V3),
    ("lossless-v3-f32-smooth", "f32-smooth", V3),
    ("lossless-v3-f64-smooth", "f64-smooth", V3),
    ("lossless-v3-f32-lattice", "f32-lattice", V3),
    ("lossless-v3-f32-packed", "f32-packed", V3),
    # version 4: the blend of predictors (mode 5, tool 2), one brick each: copies from
    # two periods, a fill value of 0 (float32) and of NaN (float64)
    ("lossless-v4-f32-periodic", "f32-periodic", {"brick": 32, "predict_version": 4}),
    ("lossless-v4-f32-masked", "f32-masked", {"brick": 32, "predict_version": 4}),
    ("lossless-v4-f64-masked", "f64-masked", {"brick": 32, "predict_version": 4}),
    # version 5: the low-value models under a noise floor (flag 64), one brick
    ("lossless-v5-u8-floor", "v5-u8-floor", {"brick": 32, "predict_version": 5}),
    # version 6: the fitted float predictor (mode 5, tool 3), one brick
    ("lossless-v6-f32-fit", "f32-rough", {"brick": 32, "predict_version": 6}),
    # version 7: the texture bias (flag 128, with the low-value models), one brick
    ("lossless-v7-u8-tex", "v2-u8", {"brick": 32, "predict_version": 7}),
    # version 8: the mixed estimates (flag 256: a second flags byte), one brick
    ("lossless-v8-u8-mix", "v2-u8", {"brick": 32, "predict_version": 8}),
    # version 9: the local fit (flag 512 in the second flags byte), alone and with a mask
    # and the palette (the refits skipped at masked pairs), one brick each
    ("lossless-v9-u8-local", "v2-u8", {"brick": 32, "predict_version": 9}),
    ("lossless-v9-u8-local-mask", "v2-u8-background", {"brick": 32, "predict_version": 9}),
    ("lossless-v9-i16-local-palette", "v2-i16", {"brick": 32, "predict_version": 9}),
    # version 10: the fitted float predictor with a box fit (tool 3, predictor byte 8 + P)
    ("lossless-v10-f32-fit-box", "f32-wide", {"brick": 64, "predict_version": 10}),
    # a 4-D series with its time steps interleaved (header "layout": "interleaved")
    ("lossless-interleaved-u8", "series-u8", {"interleave": True}),
    # 64-bit integers (session 32): uint64 label ids, one past 2^63, and a wide corner
    ("lossless-labels-u64", "labels-u64", {}),
    # a (z, y, x, c) colour volume stored as the series of its channels (header
    # "channels": "last"; session 32), the channels interleaved
    # (tuples=False since session 33, whose default stores this volume as a tuple palette)
    ("lossless-channels-rgb-u8", "rgb-u8", {"brick": 32, "tuples": False}),
    # tuple palettes (session 33, header "channels": {"axis", "tuples"}, palette chunk
    # (1, 0)): RGBA last through a colour wheel (K <= 256: a uint8 index volume), and two
    # int16 channels first with K > 256 (a uint16 index volume, signed values)
    ("lossless-tuples-rgba-u8", "rgba-u8", {"brick": 32, "tuples": True}),
    ("lossless-tuples-first-i16", "pair-i16-first", {"brick": 32, "tuples": True}),
    # counts times a constant, a third of them through another path (their last bits
    # moved): a lattice whose step the values of least magnitude give (session 33)
    ("lossless-f32-counts", "f32-counts", {"brick": 32}),
    # two slices coded as one plane by the planar predictor (session 33: flag 1024, the
    # second flags byte's bit 2), one brick
    ("lossless-v8-i16-plane", "thin-i16", {"brick": (2, 80, 96)}),
    # a label map upsampled by nearest neighbour, 2x along z and 3x along x, cropped so
    # that runs start mid-brick (session 34: mode 6, the brick shrunk to one slice a run)
    ("lossless-v8-u8-repeat", "labels-runs", {"brick": 32}),
    # a formula's field on a grid centred on the origin, its own mirror image along z
    # (odd length) and y (session 37: mode 7, the brick cut to its first half along both)
    ("lossless-v8-u8-mirror", "mirror-u8", {"brick": (31, 32, 32)}),
    # detector frames: photons (Poisson) times a gain of 30 plus read noise, a dead pixel
    # (session 38: mode 8, a gain comb, the counts and the residues coded apart)
    ("lossless-v8-i16-gain", "gain-i16", {"brick": (12, 32, 32)}),
    # a narrow band over iid noise 0..14 (session 39: flag 2048, the second flags byte's
    # bit 3, LOWM: the low-value class's mantissa bits keyed on the prediction)
    ("lossless-v8-u8-lowm", "lowm-u8", {"brick": (12, 32, 32)}),
]


def noise_floor(cut):
    """``cut`` with its zeros replaced by a fixed pattern of the values 0..5 (a noise
    floor as magnitude images have, with a histogram no residual model fits)."""
    import numpy as np

    z, y, x = np.indices(cut.shape)
    table = np.array([0, 2, 3, 3, 3, 4, 2, 0, 3, 5, 1, 3, 2], dtype=cut.dtype)
    return np.where(cut == 0, table[(z * 131 + y * 71 + x * 37 + (x * y) % 11) % 13], cut)


def place_specials(f, at=0):
    """Float32 ``f`` with NaN (one with a payload), -0.0, +-Inf and the smallest
    denormals at fixed flat positions from ``at`` on."""
    import numpy as np

    flat = f.reshape(-1)[at:]
    flat[1007:1009] = (np.nan, np.array([0x7FC01234], np.uint32).view(np.float32)[0])
    flat[1108:1111] = (-0.0, np.inf, -np.inf)
    flat[1313], flat[1567] = 1e-45, -1e-45  # the smallest denormals
    return f


def lowm_source():
    """12 x 32 x 32 uint8: iid uniform noise 0..14 everywhere (a scan's noise floor), a
    ball of radius 9 raised into a narrow band (70 + 10 x a slow wave, plus the noise)."""
    import numpy as np

    rng = np.random.default_rng(39)
    z, y, x = np.indices((12, 32, 32))
    v = rng.integers(0, 15, size=z.shape)
    ball = (z - 6) ** 2 + (y - 16) ** 2 + (x - 16) ** 2 <= 81
    v[ball] += (70 + 10 * np.sin(x * 0.3) * np.cos(y * 0.2)).astype(np.int64)[ball]
    return v.astype(np.uint8)


def lossless_source(recipe: str):
    """The volume a lossless example codes: the wavelet cut with a zeroed background, the
    scaled int16 cut (a sparse histogram: a palette), or floats with NaN, -0.0, Inf and
    denormals."""
    import numpy as np

    if recipe == "series-u8":  # 4 time steps of a cut, a sparse pattern changing with t
        from volpack.demo import load_demo_volume

        cut = load_demo_volume().data[30:38, 40:64, 40:68].astype(np.int64)
        t = np.arange(4).reshape(4, 1, 1, 1)
        z, y, x = np.indices(cut.shape)
        return np.minimum(cut + ((x + 2 * y + 3 * t) % 5 == 0) * t, 255).astype(np.uint8)
    if recipe == "rgb-u8":  # the cut through a colour map: (z, y, x, 3), RGB last
        cut = wavelet_source("u8").astype(np.float64) / 255
        return (np.stack([cut**0.6, cut, cut**1.6], -1) * 255).astype(np.uint8)
    if recipe == "f32-counts":  # a density from counts: k * c, and k / (1 / c) moved
        z, y, x = np.indices((24, 28, 32))
        rate = 2000 * (1.4 + np.sin(x / 5) * np.cos(y / 7) + 0.3 * np.sin(z / 4))
        k = np.rint(rate).astype(np.int64) + (x * 7 + y * 13 + z * 29) % 41 - 20
        c = np.float32(0.000515625)
        f = (k * c).astype(np.float32)
        two = (x + 2 * y + 3 * z) % 3 == 0
        f[two] = k[two].astype(np.float32) / np.float32(1 / c) * np.float32(1.0000019)
        return f
    if recipe == "rgba-u8":  # the cut through a colour wheel and an opacity ramp, RGBA last
        cut = wavelet_source("u8")
        turn = 2 * np.pi * 0.8 * cut.astype(np.float64) / 255
        wheel = [127.5 + 127 * np.cos(turn + k * 2 * np.pi / 3) for k in range(3)]
        return np.stack([*wheel, np.minimum(3 * cut.astype(np.int64), 255)], -1).astype(np.uint8)
    if recipe == "pair-i16-first":  # two int16 channels first: the scaled cut, a z ramp
        cut = wavelet_source("u8").astype(np.int16)
        z = np.arange(cut.shape[0], dtype=np.int16)[:, None, None]
        return np.stack([cut * 37 - 3000, -2 * cut + 50 * (z // 5)])
    if recipe == "labels-u64":  # the label cut as uint64 ids, a corner of wide values
        lab = np.digitize(wavelet_source("u8"), [40, 90])
        lab[:16, :16, :16] = 0
        out = np.array([0, 2**63 + 12345, 9876543210987], np.uint64)[lab]
        corner = wavelet_source("u8")[16:, 16:, 16:].astype(np.uint64)
        out[16:, 16:, 16:] = (corner << np.uint64(40)) + 7
        return out
    if recipe == "thin-i16":  # two slices 12 apart of the bundled MRI, 80 x 96, as int16
        from volpack.demo import load_demo_volume

        return load_demo_volume().data[30:54:12, 20:100, 16:112].astype(np.int16) - 100
    if recipe == "labels-runs":  # four tissue classes, upsampled 2x in z, 3x in x, cropped
        lab = np.digitize(wavelet_source("u8"), [40, 90, 140]).astype(np.uint8)
        return np.ascontiguousarray(np.repeat(np.repeat(lab, 2, axis=0), 3, axis=2)[1:, :, 2:])
    if recipe == "lowm-u8":  # iid uniform noise 0..14, a band of 70..90 in a ball
        return lowm_source()
    if recipe == "gain-i16":  # 12 frames of 32 x 32: 30 ADU a photon, read noise sigma 3
        rng = np.random.default_rng(38)
        yy, xx = np.meshgrid(np.arange(32) - 15.5, np.arange(32) - 15.5, indexing="ij")
        lam = 0.3 + 2.0 * np.exp(-(((np.hypot(yy, xx) - 9) / 2) ** 2))
        v = rng.poisson(lam, size=(12, 32, 32)) * 30 + np.rint(rng.normal(0, 3, (12, 32, 32)))
        v[:, 3, 7] = 0  # a dead pixel
        return v.astype(np.int16)
    if recipe == "mirror-u8":  # |psi|^2 of a 3d and 2p mix on 31 x 32 x 32, scaled to uint8
        z, y, x = np.meshgrid(*(np.linspace(-12.0, 12.0, n) for n in (31, 32, 32)), indexing="ij")
        r = np.sqrt(x**2 + y**2 + z**2) + 1e-9
        psi = r**2 * np.exp(-r / 3) * (3 * (z / r) ** 2 - 1) / 81 + 0.05 * x * np.exp(-r / 2)
        return np.rint(255 * psi**2 / (psi**2).max()).astype(np.uint8)
    if recipe == "v5-u8-floor":  # the head over a noise floor of small values, 1 rare
        return noise_floor(lossless_source("v2-u8-background"))
    if recipe.startswith("v2-"):  # 32^3 cuts of the bundled MRI: head and background, tissue
        from volpack.demo import load_demo_volume

        d = load_demo_volume().data
        if recipe == "v2-u8-background":
            cut = d[16:48, 24:56, 24:56].copy()
            cut[cut < 60] = 0
            return cut
        cut = np.ascontiguousarray(d[30:62, 40:72, 40:72])
        return cut if recipe == "v2-u8" else cut.astype(np.int16) * 37 - 3000
    if recipe == "u8-background":
        cut = wavelet_source("u8").copy()
        cut[cut < 60] = 0
        return cut
    if recipe == "labels-2x":  # the label cut resampled to half the spacing in z and y
        return np.repeat(np.repeat(wavelet_source("labels"), 2, axis=0), 2, axis=1)
    if recipe in ("f32-smooth", "f64-smooth"):  # a smooth field, full mantissas, specials
        z, y, x = np.indices((20, 24, 28))
        f = np.sin(x * 0.21 + z * 0.05) * np.cos(y * 0.17) * 80.0 + z * 0.3
        f = f.astype(np.float32 if recipe == "f32-smooth" else np.float64)
        f[3, 4, 5:7] = (np.nan, -0.0)
        f[9, 9, 9] = 5e-324 if recipe == "f64-smooth" else 1e-42
        return f
    if recipe == "f32-periodic":  # a unit cell of 14 x 24 x 20 and copies of its start
        z, y, x = np.indices((20, 24, 28))
        f = wavelet_source("u8") * 1.37 - 40.0 + z * 0.011 + y * y * 0.0007 - x * 0.05
        f = f.astype(np.float32)
        f[:, :, 20:] = f[:, :, :8]
        f[14:] = f[:6]
        f[1, 2, 3:5] = (np.nan, -0.0)
        return f
    if recipe in ("f32-masked", "f64-masked"):  # a smooth blob in a fill of 0 or NaN
        z, y, x = np.indices((20, 24, 28))
        f = np.sin(x * 0.21 + z * 0.05) * np.cos(y * 0.17) * 80.0 + z * 0.3
        f = f.astype(np.float32 if recipe == "f32-masked" else np.float64)
        f[(z - 10) ** 2 + (y - 12) ** 2 + (x - 14) ** 2 > 80] = (
            0.0 if recipe == "f32-masked" else np.nan
        )
        f[10, 12, 14:17] = (-0.0, np.inf, 5e-324 if recipe == "f64-masked" else 1e-42)
        return f
    if recipe == "f32-rough":  # a smooth field under correlated noise, specials
        rng = np.random.default_rng(7)
        z, y, x = np.indices((20, 24, 28))
        f = np.sin(x * 0.3 + z * 0.2) * np.cos(y * 0.25) * 10.0
        noise = rng.normal(0, 0.05, f.shape)
        f += noise + 0.5 * np.roll(noise, 1, axis=2) + 0.5 * np.roll(noise, 1, axis=1)
        return place_specials(f.astype(np.float32))
    if recipe == "f32-wide":  # smooth waves with no noise: a wide box fit pays, specials
        z, y, x = np.indices((10, 40, 48))
        f = np.sin(x * 0.21 + z * 0.3) * np.cos(y * 0.17) * 10.0 + np.sin(x * 0.05 + y * 0.11) * 30
        return place_specials(f.astype(np.float32), 4000)
    if recipe == "f32-lattice":  # tenths of a unit: a geopotential height in metres
        c = wavelet_source("u8").astype(np.float64)
        return (np.round(np.cumsum(c - c.mean(), axis=2) * 3 + 50000.0) * 0.1).astype(np.float32)
    if recipe == "f32-packed":  # one reference value and binary scale per slice (GRIB)
        c = wavelet_source("u8").astype(np.float64)
        k = np.cumsum(c - c.mean(), axis=2) * 5
        z = np.arange(c.shape[0]).reshape(-1, 1, 1)
        return (230.0 + 0.37 * z + 2.0 ** -(7 + z % 3) * np.round(k)).astype(np.float32)
    if recipe == "f32-field":  # full mantissas: exponent and mantissa coded apart
        z, y, x = np.indices((20, 24, 28))
        f = wavelet_source("u8") * 1.37 - 40.0 + z * 0.011 + y * y * 0.0007 - x * 0.05
        return f.astype(np.float32)
    if recipe != "f32-special":
        return wavelet_source(recipe)
    f = wavelet_source("u8").astype(np.float32) / 3
    f[2, 3:6, 4] = np.nan
    f[5, 5, 5] = -np.inf
    f[6, 6, 6] = np.inf
    f[7, 7, 7:9] = -0.0
    f[8, 8, 8] = np.float32(1e-42)  # a denormal
    return f


def make_lossless(folder: Path) -> Path:
    from volpack import api

    for stem, recipe, opts in LOSSLESS_CASES:
        path = folder / f"{stem}.vpk"
        opts = {"brick": WAVELET_BRICK, **opts}
        api.compress(lossless_source(recipe), str(path), force=True, **opts)
    return folder


# -- fast codec examples: formats/examples/fast-*.vpk ------------------------------------

FAST_CASES = [
    ("fast-u8", "u8", {"codec": "fast", "runs": False, "zstd": False}),
    ("fast-u8-background", "u8-background", {"codec": "fast", "runs": False, "zstd": False}),
    ("fast-i16-palette", "i16", {"codec": "fast", "runs": False, "zstd": False}),
    ("fast-f32-special", "f32-special", {"codec": "fast", "runs": False, "zstd": False}),
    # the run mode (the default since; the four above are the streams of before it): in
    # 32^3 bricks too, whose runs repay their two tables (runs after each predictor)
    (
        "fast-runs-mixed",
        "v2-u8-background",
        {"codec": "fast", "runs": True, "rows": False, "zstd": False},
    ),
    (
        "fast-runs-labels",
        "labels",
        {"codec": "fast", "runs": True, "rows": False, "zstd": False, "brick": 32},
    ),
    (
        "fast-runs-u8-background",
        "u8-background",
        {"codec": "fast", "runs": True, "rows": False, "zstd": False, "brick": 32},
    ),
    # the row kinds (the default since): runs of rows that copy the row or slice above
    ("fast-rows-labels", "labels-2x", {"codec": "fast", "zstd": False, "brick": 32}),
    ("fast-rows-mixed", "v2-u8-background", {"codec": "fast", "zstd": False}),
    # zstd bricks (mode 3, the default since): label bricks and others beside them
    ("fast-zstd-labels", "labels-2x", {"codec": "fast", "brick": 32}),
    ("fast-zstd-mixed", "v2-u8-background", {"codec": "fast"}),
]


def make_fast(folder: Path) -> Path:
    from volpack import api

    for stem, recipe, opts in FAST_CASES:
        path = folder / f"{stem}.vpk"
        opts = {"brick": WAVELET_BRICK, **opts}
        api.compress(lossless_source(recipe), str(path), force=True, **opts)
    return folder


# -- lossy examples: formats/examples/lossy-*.vpk ------------------------------------

LOSSY_CASES = [
    ("lossy-bounded-f32", "f32", {"max_error": 0.5, "fill_value": -999.0}),
    ("lossy-bounded-i16-huffman", "i16", {"max_error": 40, "coder": "huffman"}),
    ("lossy-bounded-i16-loose", "i16", {"max_error": 400}),
    ("lossy-coef-q63-u8", "u8", {"quality": 63}),
    ("lossy-coef-threshold-i16", "i16", {"threshold": 50.0, "order": "line"}),
]


# The plane waves' shapes (-long: thin in z; -noisy: with a little noise).
WAVES = {"f32-waves": (20, 24, 28), "f32-waves-long": (12, 36, 52), "f32-waves-noisy": (12, 40, 48)}


def lossy_source(recipe: str):
    """The volume a lossy example codes; ``f32`` adds NaN, -Inf and a fill value."""
    import numpy as np

    if recipe == "f32-whole":
        return wavelet_source("u8").astype(np.float32)
    if recipe == "f32-levels":  # steps of 1/4, offset by 0.37 per z slice
        u = wavelet_source("u8").astype(np.float64)
        return (u * 0.25 + 250.0 + 0.37 * np.arange(u.shape[0])[:, None, None]).astype(np.float32)
    if recipe in WAVES:  # six plane waves: predictable from far
        rng = np.random.default_rng(17)
        shape = WAVES[recipe]
        axes = [np.arange(s, dtype=np.float64) for s in shape]
        z, y, x = np.meshgrid(*axes, indexing="ij")
        f = np.zeros(z.shape)
        for _ in range(6):
            k = rng.uniform(0.2, 1.1, 3) * rng.choice([-1, 1], 3)
            a = rng.uniform(0.5, 1.5)  # (drawn before the phase)
            f += a * np.sin(k[0] * z + k[1] * y + k[2] * x + rng.uniform(0, 6.3))
        if recipe == "f32-waves-noisy":  # and a little noise: a residual worth its tables
            f += 0.02 * rng.standard_normal(f.shape)
        return (f * 10 + 20).astype(np.float32)
    if recipe == "f32-trilinear":  # a 7x8x9 random grid interpolated trilinearly up 8x
        out = np.random.default_rng(35).normal(size=(7, 8, 9))
        for ax in range(3):
            m = out.shape[ax]
            t = np.arange((m - 1) * 8 + 1) / 8
            i0 = np.minimum(t.astype(int), m - 2)
            f = (t - i0).reshape([-1 if a == ax else 1 for a in range(3)])
            out = np.take(out, i0, axis=ax) * (1 - f) + np.take(out, i0 + 1, axis=ax) * f
        return (out * 4 + 20).astype(np.float32)
    if recipe == "f64-off":  # the f32 recipe in float64 moved off its grid of 1/3
        f = lossy_source("f32").astype(np.float64)
        ok = np.isfinite(f) & (f != -999.0)
        f[ok] += (np.arange(f.size) * 0.6180339887 % 1.0).reshape(f.shape)[ok] * 0.01
        return f
    if recipe == "f32-lowrank":  # rank 4 in whole numbers, plus a faint ramp of noise
        i, j, k = np.arange(40.0), np.arange(40.0), np.arange(48.0)
        f = np.zeros((40, 40, 48))
        for r, (p, q, s) in enumerate(((3, 5, 7), (11, 13, 2), (1, 4, 9), (6, 1, 5))):
            f += np.multiply.outer(
                np.multiply.outer(i * p % 17 - 8, j * q % 19 - 9), k * s % 23 - 11
            ) / (r + 1)
        f += (np.arange(f.size) * 0.6180339887 % 1.0).reshape(f.shape) * 0.05
        return f.astype(np.float32)
    if recipe not in ("f32", "f32-walk"):
        return wavelet_source(recipe)
    f = wavelet_source("u8").astype(np.float32) / 3
    if recipe == "f32-walk":
        c = wavelet_source("u8").astype(np.float64)
        f = (np.cumsum(c - c.mean(), axis=2) / 40).astype(np.float32)
    f[2, 3:6, 4] = np.nan
    f[5, 5, 5] = -np.inf
    f[10:12, :, 20:] = -999.0
    return f


# The float wavelet path of `bounded` (flag bit 4, lossy-1.md steps 9-13): the default
# brick (the whole volume for a float volume under a bound), where it codes shortest;
# its outliers as a bin field (outlier kind 2). lossy-bounded-f32/f64-cdf97.vpk, made
# with the same recipe at max_error 2.0 before kind 2 (their outliers a dense field,
# kind 1), and lossy-bounded-f32/f64-cdf97-bins.vpk, made before the interpolation path
# (which now codes that recipe shortest), are kept as they are: today's decoder must
# still read them, today's encoder no longer makes them.
LOSSY_CDF97_CASES = [
    # a looser bound, where the `rows` scan (order 2) codes shortest
    ("lossy-bounded-f32-cdf97-rows", "f32", {"max_error": 8.0, "fill_value": -999.0}),
    # the separable decomposition (order 3) on the MRI summed along x, where it codes
    # shortest (lossy-bounded-f32-lorenzo2d-b0.vpk, this recipe's Lorenzo coding made
    # before the separable decomposition existed, is kept as it is: decoded, no longer
    # reproduced)
    ("lossy-bounded-f32-separable", "f32-walk", {"max_error": 0.3, "fill_value": -999.0}),
]
# The interpolation path (flag bit 6, lossy-1.md steps 14-18), where it codes shortest:
# cubic (kind 1) and, in float64 with bins past 32 (raw bits), linear (kind 0)
# interpolation on the float MRI; Lorenzo in 3-D (kind 2) and within slices (kind 3) on
# the MRI summed along x (each column the previous plus an image). The float64 recipe
# is moved off its grid of 1/3 (else bins of 1/3 code it, lossy-1.md step 1). The `-b0` streams are
# today's coding (masked voxels take bin 0: they follow their prediction); the four
# without the suffix were made when masked voxels were coded with their neighbour's
# value, and are kept as they are: decoded, no longer reproduced.
LOSSY_INTERP_CASES = [
    ("lossy-bounded-f32-interp-b0", "f32", {"max_error": 2.0, "fill_value": -999.0}),
    ("lossy-bounded-f64-interp-b0", "f64-off", {"max_error": 0.01, "fill_value": -999.0}),
    ("lossy-bounded-f32-lorenzo-b0", "f32-walk", {"max_error": 0.03, "fill_value": -999.0}),
    # an undeclared fill value (-999) masked because that codes shorter
    ("lossy-bounded-f32-sentinel", "f32", {"max_error": 2.0}),
    # floats holding whole numbers under a bound below 1/2, made before the exact path
    # (which now codes this recipe shorter: lossy-bounded-f32-whole-exact.vpk) and kept as
    # it is (bins of 1, exact; decoded, no longer reproduced):
    # ("lossy-bounded-f32-whole", "f32-whole", {"max_error": 0.25}),
]
# The exact path (flag bit 7, lossy-1.md step 19), where it codes shortest: the whole
# numbers above, and the MRI on a step of 1/4 with its own offset per z slice (a packed
# field per level: no volume-wide grid, the lossless codec's lattice tool per slice).
LOSSY_EXACT_CASES = [
    ("lossy-bounded-f32-whole-exact", "f32-whole", {"max_error": 0.25}),
    ("lossy-bounded-f32-levels", "f32-levels", {"max_error": 0.01}),
    # under effort 'fast': the lattice per slice and its integers by the fast codec
    # (inner byte 6, lossy-1.md step 19b)
    ("lossy-bounded-f32-levels-fast", "f32-levels", {"max_error": 0.01, "effort": "fast"}),
]


# The coefficient coders of `bounded` (wavelet-1.md): `auto` (a byte per coefficient
# stream naming arith or arith2), the default since it was added (every recipe above
# names "arith", the default when its stream was made), on the float wavelet path and on
# the integer paths (eight bricks), and `static` (fixed rANS tables) when asked for (on
# integers: on floats the interpolation path codes this recipe shorter).
# (stem, recipe, options, brick or None for the default)
LOSSY_CODER_CASES = [
    ("lossy-bounded-f32-auto", "f32-walk", {"max_error": 0.3, "fill_value": -999.0}, None),
    ("lossy-bounded-i16-auto", "i16", {"max_error": 40}, WAVELET_BRICK),
    ("lossy-bounded-i16-static", "i16", {"max_error": 40, "coder": "static"}, WAVELET_BRICK),
]  # fmt: skip
# Today's coding of two recipes above (lossy-1.md): the interpolation path's bins in the
# adaptive binary coder (kind bit 4), and the quantised voxels in the lossless codec's
# 3-D prediction (its mode 4) in most of the eight bricks, where it saves 2 % of the
# bytes (lossy-1.md, "Decoding speed in the encoder's choice"). The same recipe coded
# before that minimum, lossy-bounded-i16-quantised-fit.vpk (one more brick in mode 4,
# by 0.8 %), is kept as it is: decoded, no longer reproduced.
# Since session 29 the default effort codes the adaptive bins on 5 of the 12 walks
# (lossy-1.md's encoder choice; the decoder reads either): the recipe's adaptive walk is
# another axis order, 2764 -> 2776 bytes. lossy-bounded-f32-interp-adaptive.vpk is kept as
# it is (decoded, no longer reproduced); the -few file is today's coding of it.
LOSSY_CODER_CASES += [
    # ("lossy-bounded-f32-interp-adaptive", "f32", {"max_error": 2.0, "fill_value": -999.0}, None),
    ("lossy-bounded-f32-interp-adaptive-few", "f32", {"max_error": 2.0, "fill_value": -999.0},
     None),
    # ("lossy-bounded-i16-quantised-fit", "i16", {"max_error": 40}, WAVELET_BRICK),
    ("lossy-bounded-i16-quantised-saving", "i16", {"max_error": 40}, WAVELET_BRICK),
]  # fmt: skip
# The quantised voxels by the long fitted predictor (lossy-1.md step 20, flag bit 3 alone):
# plane waves at 1e-4 of their range, where it codes shortest. Made by version 1 of its
# payload, which today's encoder no longer writes: kept as it is (decoded, no longer
# reproduced).
# LOSSY_CODER_CASES += [("lossy-bounded-f32-longfit", "f32-waves", {"max_error": 0.005}, None)]
# Version 2 (step 21): a reach per axis (Kz = 2 on this thin field), face classes. Its
# residual by the lossless codec's wavelet is no longer what today's encoder writes there
# (kept as it is: decoded, no longer reproduced); today's: the residual by the adaptive
# coder in activity contexts (residual type 3, step 22).
# LOSSY_CODER_CASES += [
#     ("lossy-bounded-f32-longfit-reach", "f32-waves-long", {"max_error": 0.005}, None)
# ]
LOSSY_CODER_CASES += [
    ("lossy-bounded-f32-longfit-context", "f32-waves-long", {"max_error": 0.005}, None)
]
# The residual by static rANS tables in the same contexts (residual type 4, step 23): the
# plane waves with a little noise, where its tables cost less than type 3 would save.
LOSSY_CODER_CASES += [
    ("lossy-bounded-f32-longfit-static", "f32-waves-noisy", {"max_error": 0.005}, None)
]

# effort 'fast' on integers (session 23): the quantised voxels in the fast codec's payload
# (inner byte 6, lossy-1.md "the quantised voxels by the fast codec"), every brick. Made
# before that payload kept to the fast codec's far context rule (qvox26),
# lossy-bounded-i16-fast.vpk (one brick by the near rule) is kept as it is: decoded, no
# longer reproduced; the -far file is today's coding of its recipe.
LOSSY_CODER_CASES += [
    # ("lossy-bounded-i16-fast", "i16", {"max_error": 40, "effort": "fast"}, WAVELET_BRICK),
    ("lossy-bounded-i16-fast-far", "i16", {"max_error": 40, "effort": "fast"}, WAVELET_BRICK),
    # and on floats, where it codes shorter than the interpolation path (with a mask)
    ("lossy-bounded-f32-fast", "f32", {"max_error": 2.0, "fill_value": -999.0, "effort": "fast"},
     None),
]  # fmt: skip
# The interpolation path's grouped bins (session 24, lossy-1.md step 17, kind 32 + kind):
# the walk recipe with a mask (3-D Lorenzo), and plane waves where many symbols take raw
# bits.
FAST_BINS_CASES = [
    ("lossy-bounded-f32-fastbins", "f32-walk",
     {"max_error": 0.05, "fill_value": -999.0, "effort": "fast"}, None),
    ("lossy-bounded-f32-fastbins-raw", "f32-waves", {"max_error": 0.02, "effort": "fast"}, None),
]  # fmt: skip
LOSSY_CODER_CASES += FAST_BINS_CASES
# The interpolation path's static bins with tables shared between contexts (session 35,
# lossy-1.md step 17, kind 64 + kind): a field interpolated trilinearly up 8x, whose bins
# are nearly all 0.
LOSSY_CODER_CASES += [
    ("lossy-bounded-f32-interp-shared", "f32-trilinear", {"max_error": 0.3}, None)
]


def make_lossy(folder: Path) -> Path:
    from volpack import api

    for stem, recipe, opts in LOSSY_CASES:
        path = folder / f"{stem}.vpk"
        opts = {"coder": "arith", **opts}  # the default when they were made (now auto)
        api.compress(lossy_source(recipe), str(path), brick=WAVELET_BRICK, force=True, **opts)
    for stem, recipe, opts in LOSSY_CDF97_CASES + LOSSY_INTERP_CASES + LOSSY_EXACT_CASES:
        source = lossy_source("f32" if recipe == "f64" else recipe)
        if recipe == "f64":
            source = source.astype("float64")
        api.compress(source, str(folder / f"{stem}.vpk"), force=True, coder="arith", **opts)
    for stem, recipe, opts, brick in LOSSY_CODER_CASES:
        path = folder / f"{stem}.vpk"
        api.compress(lossy_source(recipe), str(path), brick=brick, force=True, **opts)
    for stem, recipe, opts in LOSSY_TUCKER_CASES:
        api.compress(lossy_source(recipe), str(folder / f"{stem}.vpk"), force=True, **opts)
    return folder


# The Tucker codec (lossy-1.md `tucker`), chosen by a PSNR target on a low-rank field.
# Its encoder takes LAPACK's SVD, so only this machine reproduces the bytes; the test
# checks the decoded voxels (bit-exact everywhere) against their recorded hash.
LOSSY_TUCKER_CASES = [("lossy-tucker-f32-lowrank", "f32-lowrank", {"psnr": 60.0})]


# Volumes in container format version 2 (formats/vpk-2.md; every stream before these is
# version 1): the content of lossy-bounded-f32-interp-b0 (one brick; header and summary
# dictionary-coded) and of wavelet-53-arith-dfs-u8 (eight bricks).
COMPACT_CASES = [
    ("vpk2-lossy-bounded-f32", "f32", {"max_error": 2.0, "fill_value": -999.0}),
    ("vpk2-wavelet-53-arith-u8", "u8",
     {"brick": WAVELET_BRICK, "codec": "wavelet", "wavelet": "53", "coder": "arith", "order": "dfs"}),
]  # fmt: skip


def make_compact(folder: Path) -> Path:
    from volpack import api

    for stem, recipe, opts in COMPACT_CASES:
        opts = {"coder": "arith", **opts}  # the default when they were made (now auto)
        api.compress(lossy_source(recipe), str(folder / f"{stem}.vpk"), force=True, **opts)
    return folder


# animation-ibbp-bounded-u8.vpk and animation-ipb-specials-f32-exact.vpk were made before the
# bounded codec coded its quantised voxels with the lossless codec and its interpolation bins
# adaptively (lossy-1.md), which code their I- and P-frame bricks shorter; they are kept as
# decode-only goldens, and their recipes write the -fit and -adaptive files.
ANIMATION_CASES = [
    ("animation-ibbp-bounded-u8-fit", {"gop_string": "IBBP", "max_error": 2}, "roll"),
    (
        "animation-ipp-coef-quarter-u8",
        {"gop_string": "IPP", "quality": 63, "precision": "quarter"},
        "roll",
    ),
    ("animation-ibbp-whole-frame-u8", {"gop_string": "IBBP"}, "translate"),
    # animation-ipb-specials-f32.vpk was made before the bounded codec's exact path, which
    # now codes some of its bricks shorter; it is kept as a decode-only golden, and its
    # recipe writes the -exact file:
    (
        "animation-ipb-specials-f32-adaptive",
        {"gop_string": "IPB", "max_error": 0.05, "fill_value": -9999.0},
        "specials",
    ),
    ("animation-ipb-lossless-f32", {"gop_string": "IPB", "fill_value": -9999.0}, "specials"),
]


def animation_source():
    """Five frames of a crop of the bundled MRI, rolled by whole voxels (exact integers)."""
    import numpy as np

    from volpack.demo import load_demo_volume

    cut = load_demo_volume().data[30:46, 40:56, 40:64]
    return np.stack([np.roll(cut, (t // 2, t, -t), (0, 1, 2)) for t in range(5)])


def translated_source():
    """Five frames of a crop of the bundled MRI moving (0.5, 0.25, -0.75) voxels a frame
    (band-limited): lossless, two of the three predicted frames are whole-frame shifts."""
    from volpack import synth

    head = synth.head((28, 32, 36))
    return synth.translate(head, 5, step=(0.5, 0.25, -0.75), crop=(16, 20, 24))


def specials_source():
    """Five float32 frames of the synthetic head moving (0.5, 0.25, 0.75) voxels a frame,
    with special voxels: a fill-value (-9999) border that grows, NaN, +-Inf, -0.0 and a
    denormal, and an all-NaN frame (3)."""
    import numpy as np

    from volpack import synth

    a = synth.translate(synth.head((12, 16, 20)), 5, step=(0.5, 0.25, 0.75)).astype(np.float32)
    a /= np.float32(7.0)
    for t in range(5):
        a[t, :, : 2 + t, :3] = -9999.0
    a[1, 5, 5, 5], a[2, 6, 6, 6], a[2, 6, 6, 7] = np.nan, np.inf, -np.inf
    a[4, 7, 7, 7], a[4, 7, 7, 8] = -0.0, np.float32(1e-40)
    a[3] = np.nan
    return a


def make_animation(folder: Path) -> Path:
    from volpack.animation import stream as animation

    sources = {
        "roll": animation_source,
        "translate": translated_source,
        "specials": specials_source,
    }
    for stem, opts, source in ANIMATION_CASES:
        path = folder / f"{stem}.vpk"
        animation.compress(sources[source](), str(path), force=True, **opts)
    return folder


# -- octree examples: formats/examples/octree-*.vpk ------------------------------------

OCTREE_CASES = [
    ("octree-53-arith-i16", "i16", {"block": 4}),
    ("octree-bounded-u8", "u8", {"block": 4, "max_error": 3.0, "coder": "huffman"}),
]


def make_octree(folder: Path) -> Path:
    from volpack.octree import build

    for stem, recipe, opts in OCTREE_CASES:
        build(wavelet_source(recipe), str(folder / f"{stem}.vpk"), force=True, **opts)
    return folder


EXAMPLES: dict[str, Callable[[Path], Path]] = {
    "container": make_container,
    "compact": make_compact,
    "wavelet": make_wavelet,
    "lossless": make_lossless,
    "fast": make_fast,
    "lossy": make_lossy,
    "animation": make_animation,
    "octree": make_octree,
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
