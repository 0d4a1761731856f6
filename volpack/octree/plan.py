"""What an octree's header fixes (:class:`Plan`), and the node pieces the builder writes
and the reader decodes alike: the root's low-pass block, the values of a level from its
integers, and the voxels stored exactly past a bound."""

from __future__ import annotations

import dataclasses
import functools
from typing import Any

import numpy as np

from .. import __version__
from ..errors import FormatError
from . import layout
from .layout import Geometry


@dataclasses.dataclass(frozen=True)
class Plan:
    """Everything a build task needs besides its input (picklable, for Dask)."""

    shape: tuple[int, int, int]
    dtype: str
    block: int
    wavelet: str
    coder: str
    order: str
    work: str
    sb_levels: int
    bounded: tuple[tuple[str, Any], ...] | None = None  # BoundedCodec config

    @property
    def geometry(self) -> Geometry:
        return Geometry(self.shape, self.block)

    @functools.cached_property
    def codec(self):
        if self.bounded is None:
            return None
        from ..volume_codec.registry import get_codec

        return get_codec(dict(self.bounded))

    def header(self, spacing, origin) -> dict[str, Any]:
        return {
            "kind": layout.KIND,
            "volpack": __version__,
            "shape": list(self.shape),
            "dtype": np.dtype(self.dtype).newbyteorder("<").str,
            "spacing": list(spacing),
            "origin": list(origin),
            "octree": {
                "block": self.block,
                "depth": self.geometry.depth,
                "wavelet": self.wavelet,
                "coder": self.coder,
                "order": self.order,
                "work": self.work,
                "super_levels": self.sb_levels,
            },
            "codec": None if self.bounded is None else dict(self.bounded),
        }

    @classmethod
    def from_header(cls, h: dict, max_voxels: int = 1 << 34) -> Plan:
        """The plan a stored header describes, every field checked (a header is JSON
        that may hold anything); the shape within ``max_voxels``."""
        from ..format import header as hh
        from ..volume_codec.codec import CODER_NAMES, ORDER_NAMES, WAVELET_NAMES

        o = hh.field(h, "octree")
        codec = h.get("codec")
        if codec is not None:
            # imported here: an integer tree has no codec, and the registry imports
            # every codec (entropy coders included), 50-65 ms of a walk's start
            from ..volume_codec.registry import get_codec

            c = get_codec(codec)  # checks it
            integer = hh.dtype(hh.field(h, "dtype")).kind in "iu"
            if c.codec_id != "bounded" or c.integer != integer:
                raise FormatError(f"expected a codec for {h['dtype']} voxels, found {codec!r:.80}")
            bounded = tuple(sorted(codec.items()))
        else:
            bounded = None
        plan = cls(
            shape=hh.shape(hh.field(h, "shape"), "shape", (3,), max_voxels),  # type: ignore[arg-type]
            dtype=hh.dtype(hh.field(h, "dtype")).newbyteorder("=").str,
            block=hh.integer(hh.field(o, "block", "octree header"), "block", 2, 1024),
            wavelet=hh.text(hh.field(o, "wavelet", "octree header"), "wavelet", WAVELET_NAMES),
            coder=hh.text(hh.field(o, "coder", "octree header"), "coder", CODER_NAMES),
            order=hh.text(hh.field(o, "order", "octree header"), "order", ORDER_NAMES),
            work=hh.dtype(hh.field(o, "work", "octree header"), "work", "i").str,
            sb_levels=hh.integer(
                hh.field(o, "super_levels", "octree header"), "super_levels", 0, 64
            ),
            bounded=bounded,
        )
        if np.dtype(plan.work).name not in ("int32", "int64"):
            raise FormatError(f"expected an int32 or int64 work dtype, found {plan.work!r}")
        return plan

    @functools.cached_property
    def clip_range(self) -> tuple[int, int] | None:
        """``(min, max)`` of the dtype that :func:`to_values` clips into, for a tree
        without a codec whose range int64 holds (not uint64), else None."""
        if self.codec is not None or np.dtype(self.dtype) == np.uint64:
            return None
        info = np.iinfo(np.dtype(self.dtype))
        return int(info.min), int(info.max)


def to_values(plan: Plan, a: np.ndarray) -> np.ndarray:
    """Voxels of the output dtype from ``A_L`` integers (clipped into the dtype)."""
    dtype = np.dtype(plan.dtype)
    if plan.codec is not None:
        return plan.codec._reconstruct(a, dtype)
    info = np.iinfo(dtype)
    return np.clip(a, info.min, info.max).astype(dtype)


def encode_lowpass(plan: Plan, low: np.ndarray) -> bytes:
    from ..volume_codec.codec import WaveletCodec, ZstdCodec

    info = np.iinfo(np.int32)
    if low.size and info.min <= low.min() and low.max() <= info.max:
        body = WaveletCodec(plan.wavelet, plan.coder, plan.order).encode(low.astype(np.int32))
        return b"\x00" + body
    return b"\x01" + ZstdCodec().encode(low.astype(np.int64))


def decode_lowpass(plan: Plan, data: bytes, shape) -> np.ndarray:
    from ..volume_codec.codec import WaveletCodec, ZstdCodec

    if not data:
        raise FormatError("octree root: empty low-pass section")
    if data[0] == 0:
        c = WaveletCodec(plan.wavelet, plan.coder, plan.order)
        return c.decode(data[1:], tuple(shape), np.int32).astype(plan.work)
    if data[0] == 1:
        return ZstdCodec().decode(data[1:], tuple(shape), np.int64).astype(plan.work)
    raise FormatError(f"octree root: expected low-pass mode 0 or 1, found {data[0]}")


def apply_corrections(plan: Plan, data: bytes, values: np.ndarray) -> None:
    """Put the exactly stored voxels of a level-1 node back into its level-0 values."""
    from ..volume_codec.lossy import apply_corrections as apply

    apply(data, values, "octree node")
