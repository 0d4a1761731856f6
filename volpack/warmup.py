"""Compile every kernel path once (``volpack warmup``), so the on-disk cache is warm."""

from __future__ import annotations

import time

import numpy as np


def warm() -> dict:
    """Run each codec path on tiny bricks of each integer dtype; return what was done."""
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
    paths = _warm_beyond_bricks()
    return {
        "kernels": n,
        "paths": paths,
        "seconds": time.perf_counter() - t0,
        "cache_dir": str(_jit.cache_dir()),
        "cache": _jit.CACHE,
    }


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
    for cls in ("post", "pre", "preintegrated"):
        for shading in ("none", "phong") + (
            ("centroid", "preintegrated") if cls == "preintegrated" else ()
        ):
            img = render(vol, tf=tab, camera=cam, classification=cls, shading=shading)
            if not np.all(np.isfinite(img)):
                raise AssertionError(f"warm-up render {cls}/{shading} is not finite")
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
