"""Frame sources of an animation: a 4-D array or volume, a ``(t, z, y, x)`` file (memory
mapped where the format allows), a glob pattern of 3-D files in natural name order or a
list of them, read one frame at a time so that a long sequence never sits in memory."""

from __future__ import annotations

import dataclasses
import glob
import os
import re
from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import FormatError
from ..volume import Volume, require_voxels

# -- frame sources -----------------------------------------------------------------------


@dataclasses.dataclass
class FrameSource:
    """A sequence of 3-D frames read one at a time."""

    shape: tuple[int, int, int, int]
    dtype: np.dtype
    get: Callable[[int], np.ndarray]
    spacing: tuple[float, float, float] = (1.0, 1.0, 1.0)
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    meta: dict = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        require_voxels(self.shape)


def _natural_key(path: str) -> list:
    return [int(p) if p.isdigit() else p for p in re.split(r"(\d+)", path)]


def frame_paths(pattern: str) -> list[str]:
    """Files matching a glob pattern, in natural name order (``f2`` before ``f10``)."""
    paths = sorted(glob.glob(pattern), key=_natural_key)
    if not paths:
        raise FormatError(f"expected files matching {pattern!r}, found none")
    return paths


def is_pattern(source: Any) -> bool:
    return isinstance(source, str) and any(c in source for c in "*?[")


def open_frames(source: Any, **read_options: Any) -> FrameSource:
    """A :class:`FrameSource` over a ``(t, z, y, x)`` array or Volume (memory-mapped
    arrays stay on disk), a 4-D file, a glob pattern or a list of 3-D files."""
    from .. import io as vio

    if isinstance(source, FrameSource):
        return source
    if isinstance(source, (str, os.PathLike)) and not is_pattern(str(source)):
        source = vio.read_volume(str(source), **read_options)
    if isinstance(source, Volume) or isinstance(source, np.ndarray):
        vol = source if isinstance(source, Volume) else Volume(source)
        data = vol.data if vol.data.ndim == 4 else vol.data[None]
        return FrameSource(
            tuple(data.shape), data.dtype, lambda t: np.asarray(data[t]), vol.spacing,
            vol.origin, dict(vol.meta),
        )  # fmt: skip
    paths = frame_paths(source) if is_pattern(source) else [str(p) for p in source]
    if not paths:
        raise FormatError("expected at least one frame file, found an empty list")
    heads = [vio.read_header(p, **read_options) for p in paths]
    first = heads[0]
    for p, h in zip(paths, heads):
        if tuple(h["shape"]) != tuple(first["shape"]) or np.dtype(h["dtype"]) != np.dtype(
            first["dtype"]
        ):
            raise FormatError(
                f"expected every frame to be {tuple(first['shape'])} {np.dtype(first['dtype'])} "
                f"like {paths[0]!r}, found {tuple(h['shape'])} {np.dtype(h['dtype'])} in {p!r}"
            )
    if len(first["shape"]) != 3:
        raise FormatError(f"expected 3-D frame files, found shape {first['shape']} in {paths[0]!r}")

    def get(t: int) -> np.ndarray:
        return vio.read_volume(paths[t], **read_options).data

    return FrameSource(
        (len(paths), *first["shape"]), np.dtype(first["dtype"]), get,
        tuple(first["spacing"]), tuple(first["origin"]), {"frames": len(paths)},
    )  # fmt: skip
