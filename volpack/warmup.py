"""Compile every kernel path once (``volpack warmup``), so the on-disk cache is warm."""

from __future__ import annotations

import itertools
import time

import numpy as np


def warm() -> dict:
    """Run each wavelet codec path on tiny bricks of each integer dtype, the default
    coders on each of :data:`CODEC_DTYPES` and the renderer on each dtype it samples;
    return what was done."""
    from . import _jit
    from .volume_codec.codec import CODER_NAMES, ORDER_NAMES, WAVELET_NAMES, WaveletCodec

    t0 = time.perf_counter()
    rng = np.random.default_rng(0)
    n = 0
    for dtype in (np.uint8, np.int16, np.int32):
        info = np.iinfo(dtype)
        brick = rng.integers(max(info.min, -1000), min(info.max, 1000), size=(9, 10, 11)).astype(
            dtype
        )
        for wavelet in WAVELET_NAMES:
            for coder in CODER_NAMES:
                for order in ORDER_NAMES:
                    c = WaveletCodec(wavelet=wavelet, coder=coder, order=order)
                    if not np.array_equal(
                        c.decode(c.encode(brick), brick.shape, brick.dtype), brick
                    ):
                        raise AssertionError(f"warm-up round trip failed for {c}")
                    n += 1
    n += _warm_codecs()
    paths = _warm_beyond_bricks()
    return {
        "kernels": n,
        "paths": paths,
        "seconds": time.perf_counter() - t0,
        "cache_dir": str(_jit.cache_dir()),
        "cache": _jit.CACHE,
    }


# The dtypes volumes come in most (8-bit MRI, CT, 16-bit scans and microscopy, float
# fields): the default coders' kernels are typed by them, so each has samples of its own.
CODEC_DTYPES = (np.uint8, np.int16, np.uint16, np.float32)


def _sample(dtype, noise: float = 4.0, levels: int = 0) -> np.ndarray:
    """A small smooth volume of ``dtype`` with ``noise`` (or on ``levels`` values, as a
    label map or a coarsely quantised scan) and a zeroed corner (the background mask's
    path), spanning a range of that dtype's kind."""
    z, y, x = np.mgrid[:20, :22, :24]
    jitter = np.random.default_rng(2).normal(0, noise, z.shape)
    field = 900 * np.sin(x / 5) * np.cos(y / 4) + 40 * z + jitter
    if levels:
        field = np.round((field - field.min()) / np.ptp(field) * (levels - 1)) * 90
    if dtype == np.uint8:
        field = field / 12 + 120
    elif dtype == np.uint16:
        field = field + 2000
    if np.issubdtype(dtype, np.integer):
        field = np.clip(field, np.iinfo(dtype).min, np.iinfo(dtype).max)
    a = field.astype(dtype)
    a[:6, :7, :8] = 0
    return a


def _warm_codecs() -> int:
    """Compress and decompress a sample of each of :data:`CODEC_DTYPES` the ways a user
    does most (lossless by default and by the fast codec; lossy at a bound by default
    and with ``effort='fast'``), each checked against its input; return how many."""
    from .api import compress_array, decompress_array

    n = 0
    # noisy, smooth, on few values; in one brick and in bricks of 16 (partial ones too):
    # the coders' paths depend on the data and the bound, and a kernel writing into a
    # brick of a larger volume is typed apart from one writing a whole array
    variants = [({"noise": 4.0}, {})] + [
        (data, {"brick": 16}) for data in ({"noise": 4.0}, {"noise": 0.0}, {"levels": 7})
    ]
    for dtype, (data, more) in itertools.product(CODEC_DTYPES, variants):
        a = _sample(dtype, **data)
        ways = [dict(more), {"codec": "fast", **more}]
        for rel, effort in itertools.product((1e-2, 1e-3, 1e-4), ("default", "fast")):
            ways.append({"max_error": rel * float(np.ptp(a)), "effort": effort, **more})
        for opts in ways:
            back = decompress_array(compress_array(a, **opts))
            err = np.abs(back.astype(np.float64) - a.astype(np.float64)).max()
            if err > opts.get("max_error", 0.0):
                raise AssertionError(f"warm-up {np.dtype(dtype)} {opts} missed its bound")
            n += 1
    return n + _warm_data_dependent()


def _warm_data_dependent() -> int:
    """Run directly the kernels that only data larger or other than a sample picks (a
    storm field's float bricks on few values, its interpolated bricks under --effort
    fast, smooth fields at mid bounds), each round trip checked; return how many."""
    from .volume_codec import bounded_interp as interp
    from .volume_codec import bounded_longfit as longfit
    from .volume_codec import labels

    rng = np.random.default_rng(3)
    r = rng.integers(-40, 40, size=(6, 7, 8))
    if not np.array_equal(longfit.decode_static(longfit.code_static(r), r.shape), r.ravel()):
        raise AssertionError("warm-up long-fit static residuals round trip failed")
    # the lookup into a float brick's palette (its values' ordered bits: int32 or int64),
    # by ranks of up to 256 labels (uint8) and more (uint16)
    for dtype, k in itertools.product((np.int32, np.int64), (3, 300)):
        palette = np.arange(k, dtype=dtype) * 7 - 5
        ranks = rng.integers(0, k, size=(4, 5, 6))
        back = labels.decode(labels.encode(ranks, k), ranks.shape, k, palette)
        if not np.array_equal(back, palette[ranks]):
            raise AssertionError(f"warm-up {np.dtype(dtype)} label palette round trip failed")
    g = np.cumsum(rng.normal(0, 1, (8, 9, 10)), axis=2)  # the static rANS bins' walk
    inner, _ = interp.encode(g, 0.1, tried=interp.TRIED_FAST[:1], codings=("static",))
    if np.abs(interp.decode(inner, g.shape, 0.1) - g).max() > 0.05 + 1e-9:
        raise AssertionError("warm-up interpolation static bins missed their bound")
    return 4


def warm_render(cam=None) -> None:
    """Render a sample of each dtype the ray caster samples as it is
    (:data:`~volpack.render.prepared.SAMPLED`; its kernels are typed by it) in every
    classification and shading, with a smooth semi-transparent and an opaque transfer
    function as a user's (smooth tables take the nearest-entry march, an opaque one the
    refined segments), through ``cam`` (default: 6x5 pixels). Benchmarks call it to
    keep the compiler out of their timings."""
    from .render.camera import Camera
    from .render.prepared import SAMPLED
    from .render.raycast import render
    from .render.transfer import TransferFunction

    cam = cam or Camera(size=(6, 5))
    for dtype in SAMPLED:
        vol = _sample(np.uint8 if dtype == np.int8 else dtype)
        vol = (vol // 2).astype(np.int8) if dtype == np.int8 else vol
        lo, hi = float(vol.min()), float(vol.max())
        r = hi - lo
        tfs = (
            TransferFunction(((lo + 0.1 * r, 0, 0, 0, 0), (lo + 0.4 * r, 0.9, 0.6, 0.5, 0.02),
                              (hi, 1, 1, 1, 0.15))),
            TransferFunction(((lo + 0.3 * r, 0, 0, 0, 0), (lo + 0.45 * r, 0.9, 0.75, 0.6, 0.9),
                              (hi, 1, 1, 1, 1))),
        )  # fmt: skip
        for tf in tfs:
            for cls in ("post", "pre", "preintegrated"):
                for shading in ("none", "phong") + (
                    ("centroid", "preintegrated") if cls == "preintegrated" else ()
                ):
                    img = render(vol, tf=tf, camera=cam, classification=cls, shading=shading)
                    if not np.all(np.isfinite(img)):
                        raise AssertionError(
                            f"warm-up render {np.dtype(dtype)} {cls}/{shading} is not finite"
                        )


def _warm_beyond_bricks() -> list[str]:
    """Run the renderer, animation, octree and mesh paths once on tiny inputs, each
    checked against what it must give back; return their names."""
    import io
    import tempfile

    from .animation import stream as animation
    from .octree import Octree, build
    from .render.camera import Camera
    from .render.lod import paged_volume
    from .render.raycast import render
    from .render.tetra import render_mesh
    from .tetra.mesh import TetMesh
    from .tetra.stream import compress_mesh, decompress_mesh

    done = []
    rng = np.random.default_rng(1)
    vol = rng.integers(0, 200, size=(12, 13, 14)).astype(np.uint8)
    tab = np.clip(rng.random((16, 4)), 0, 1)
    tab[:2, 3] = 0.0  # a transparent end, as real transfer functions have
    cam = Camera(size=(6, 5))
    warm_render(cam)
    done.append("render")
    frames = np.stack([np.roll(vol, t, axis=2) for t in range(3)])
    buf = io.BytesIO()
    animation.compress(frames, buf, gop_string="IBP", max_error=1)
    with animation.AnimationReader(buf.getvalue()) as r:
        if np.abs(r.frames().astype(int) - frames).max() > 1:
            raise AssertionError("warm-up animation exceeded its bound")
    done.append("animation")
    with tempfile.TemporaryDirectory() as d:
        build(vol, f"{d}/o.vpk", block=4)
        with Octree(f"{d}/o.vpk") as t:
            if not np.array_equal(t.decode(0).data, vol):
                raise AssertionError("warm-up octree round trip failed")
            from .octree import select

            for grads in (False, True):  # walk and render --budget draw with gradients
                pv = paged_volume(t, select.by_level(t, 1), gradients=grads)
                render(pv, tf=tab, camera=cam, shading="phong")
    done.append("octree")
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], float)
    tets = np.array([[0, 1, 2, 3], [1, 2, 3, 4]])
    buf = io.BytesIO()
    compress_mesh(TetMesh(pts, tets, point_data={"f": pts[:, 0]}), buf)
    m = decompress_mesh(buf.getvalue())
    if len(m.tets) != 2:
        raise AssertionError("warm-up mesh round trip failed")
    render_mesh(m.points, m.tets, m.point_data["f"], tf=tab, camera=cam, shading="phong")
    done.append("mesh")
    return done
