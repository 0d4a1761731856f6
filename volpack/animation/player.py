"""Play an animation ``.vpk``: decode on the playback schedule, render, write a movie.

The stream is read front to back, in storage order, whether it is a file or a pipe, so
frames follow the one-decode-per-step schedule of :func:`volpack.animation.gop.play` (two decodes
before the first frame, then one per displayed frame) and a truncated or damaged stream
plays up to the damage and then raises :class:`~volpack.errors.FormatError` naming the
frame. The transfer function's value range is fixed for the whole animation: the range
recorded in the file's summary, else the first frame's.

A 4-D series that is not an animation (a volume ``.vpk`` of shape ``(t, z, y, x)``, or
any 4-D volume file: an fMRI run, a diffusion series) plays its time steps in order: a
``.vpk`` stored frame by frame decodes one time step a frame, one stored interleaved (or
read from a pipe) is decoded whole before the first (its bricks hold every time step).
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from ..errors import FormatError, reading


@dataclasses.dataclass
class FrameStats:
    """One displayed frame: its type as coded, its chunk size, and the time spent."""

    t: int
    type: str
    nbytes: int
    decode_ms: float
    render_ms: float = 0.0


class _Stream:
    """A file read strictly forward (the container then streams it record by record)."""

    def __init__(self, f) -> None:
        self._f = f

    def read(self, n: int = -1) -> bytes:
        return self._f.read(n)

    def seekable(self) -> bool:
        return False


def recorded_range(path: str) -> tuple[float, float] | None:
    """The value range in the summary of an intact animation file, else None."""
    from ..format.container import Reader

    try:
        with Reader(path) as r:
            vr = (r.summary or {}).get("value_range")
    except (FormatError, OSError):
        return None
    from ..format.header import recorded_range as checked

    return checked({"value_range": vr})


def frame_count(path: str) -> int | None:
    """The number of frames the header of ``path`` announces (None if unreadable)."""
    from ..format.container import Reader

    try:
        with open(path, "rb") as f, Reader(_Stream(f)) as r:
            shape = r.header.get("shape")
    except (FormatError, OSError):
        return None
    ok = isinstance(shape, list) and shape and isinstance(shape[0], int) and shape[0] > 0
    return int(shape[0]) if ok else None  # a bad shape is reported by the decoder


def play(source: Any) -> Iterator[tuple[np.ndarray, FrameStats, dict]]:
    """Yield ``(frame, stats, header)`` in display order; ``stats.decode_ms`` is the
    decoding done during that step (the first step holds the two start-up decodes). A
    path (or ``'-'``) that is not an animation plays as a 4-D series (:func:`series`)."""
    if isinstance(source, str) and _kind(source) != "animation":
        yield from series(source)
        return
    own = None
    if isinstance(source, str) and source != "-":
        own = open(source, "rb")  # noqa: SIM115 - closed below
        src = _Stream(own)
    elif source == "-":
        from ..format.streams import stdin

        src = _Stream(stdin())
    else:
        src = source
    try:
        with reading(source if own is not None else None):  # the CLI names the file
            yield from _frames(src)
    finally:
        if own is not None:
            own.close()


def _frames(src: Any) -> Iterator[tuple[np.ndarray, FrameStats, dict]]:
    """:func:`play` of an opened source."""
    from . import gop, specials
    from .stream import AnimationReader, decode_frame

    reader = AnimationReader(src)
    records = iter(reader._r)
    coded: dict[int, tuple[str, int]] = {}
    spent = [0.0]

    def decode(t: int, prev, nxt):
        t0 = time.perf_counter()
        try:
            tt, node, payload = next(records)
        except StopIteration:
            raise FormatError(f"stream ends before frame {t}") from None
        except FormatError as e:
            raise FormatError(f"frame {t}: {e}") from None
        if (tt, node) != (t, 0):
            raise FormatError(f"expected frame {t} next in the stream, found chunk ({tt}, {node})")
        try:
            kind, frame = decode_frame(
                payload,
                reader.shape[1:],
                reader.dtype,
                prev,
                nxt,
                reader.settings,
                reader.brick,
            )
        except FormatError as e:
            raise FormatError(f"frame {t}: {e}") from None
        coded[t] = (kind, len(payload))
        spent[0] += time.perf_counter() - t0
        return specials.reference(frame, reader.settings.fill_value)

    steps = gop.play(reader.types, decode)
    while True:
        spent[0] = 0.0
        try:
            t, ref = next(steps)
        except StopIteration:
            break
        kind, nbytes = coded.pop(t, (reader.types[t], 0))
        yield ref.exact, FrameStats(t, kind, nbytes, 1000.0 * spent[0]), reader.header


def _kind(source: str) -> str | None:
    """The ``.vpk`` kind of ``source`` from its header alone, read forward (a truncated
    animation still plays up to its damage); None for another (readable) file, and
    ``"animation"`` where the header cannot be read (the animation reader then says why)."""
    from ..format.streams import vpk_kind

    if source == "-":  # peeked at, not consumed
        try:
            return vpk_kind(source)
        except (OSError, FormatError):
            return "animation"
    header = _vpk_header(source)
    return header.get("kind") if header is not None else None


def _vpk_header(source: str) -> dict | None:
    """The ``.vpk`` header of the file ``source``, read forward; None for another file,
    ``{"kind": "animation"}`` where it cannot be read (:func:`_kind`)."""
    from ..format.container import MAGIC, Reader, is_vpk
    from ..io import parse_spec

    path = parse_spec(source)[0]
    if os.path.isdir(path):  # a folder of slices
        return None
    try:
        with open(path, "rb") as f:
            if not is_vpk(f.read(len(MAGIC))):
                return None
            f.seek(0)
            with Reader(_Stream(f)) as r:
                return r.header
    except (OSError, FormatError):
        return {"kind": "animation"}


#: Names of a leading netCDF dimension that make a 3-D variable a series of 2-D fields
#: (``(time, lat, lon)``): besides these, any name starting with "time".
TIME_DIMENSIONS = ("t", "month", "months", "date", "day", "days", "year", "years", "record")


def time_major(shape, meta: dict | None) -> bool:
    """Whether a 3-D array is a series of 2-D fields: its source names its first axis as
    time (a netCDF variable ``(time, lat, lon)``; :data:`TIME_DIMENSIONS`)."""
    dims = meta.get("netcdf_dimensions") if isinstance(meta, dict) else None
    if len(tuple(shape)) != 3 or not isinstance(dims, list) or len(dims) != 3:
        return False
    first = str(dims[0]).lower()
    return first.startswith("time") or first in TIME_DIMENSIONS


def declared_fill_of(source: str) -> float | None:
    """The fill value the file ``source`` declares for its float voxels (netCDF's
    ``_FillValue``, kept in a volume ``.vpk``'s metadata), read from its header alone;
    None for none, for animations (which restore fills exactly) and for ``'-'``."""
    from ..format.header import dtype as header_dtype
    from ..io import read_header
    from ..io.registry import FORMATS, detect_format
    from ..volume import fill_in_meta

    if source == "-":
        return None
    header = _vpk_header(source)
    if header is None:
        try:
            # formats without a header reader (DICOM, AFNI, PAR/REC, slice folders) would
            # be read whole here and again to play; none of them declares a fill value
            if FORMATS[detect_format(source)].header is None:
                return None
            header = read_header(source)
        except (OSError, FormatError):
            return None
    if header.get("kind", "volume") != "volume":
        return None
    try:  # a damaged header's dtype is for the decoder to report, not this guess
        dtype = header_dtype(header.get("dtype"))
    except FormatError:
        return None
    return fill_in_meta(header.get("meta"), dtype)


def series(source: str) -> Iterator[tuple[np.ndarray, FrameStats, dict]]:
    """Yield ``(time step, stats, header)`` of a 4-D series: a volume ``.vpk`` (``'-'``
    too) or any volume file volpack reads; ``stats.type`` is ``"volume"`` and its
    ``nbytes`` the time step's share of the payload (of the file read, for other files);
    ``header`` the ``.vpk``'s (``{}`` for other files)."""
    from ..io import parse_spec, read_volume

    kind = _kind(source)
    if kind not in (None, "volume"):
        raise FormatError(
            f"expected an animation or a 4-D (t, z, y, x) series, found a .vpk of kind {kind!r} "
            f"in {source} (volpack render draws it)"
        )
    t0 = time.perf_counter()
    if kind is None:  # another volume file: read whole
        vol, header = read_volume(source), {}
        path = parse_spec(source)[0] if source != "-" else source
        nbytes = os.path.getsize(path) if os.path.isfile(path) else vol.nbytes
        data = vol.data[:, None] if time_major(vol.shape, vol.meta) else vol.data
        _four_d(data.shape, source)
        yield from _steps(data, nbytes, t0, header)
        return
    from ..volume_codec import interleave
    from ..volume_codec.stream import open as open_volume

    with reading(source if source != "-" else None), open_volume(source) as reader:
        header = reader.header
        shape = tuple(header["shape"])
        fields = time_major(shape, header.get("meta"))  # (time, lat, lon): 2-D fields
        _four_d((shape[0], 1, *shape[1:]) if fields else shape, source)
        per_t: dict[int, int] = {}  # payload bytes by time step (a pipe's: not known)
        for e in reader._r.entries if reader._r.seekable else ():
            per_t[e.t] = per_t.get(e.t, 0) + e.nbytes
        if fields or header.get("layout") == interleave.LAYOUT or source == "-":
            # every brick holds every time step (or a pipe reads every chunk first)
            data = reader.read(workers=0).data
            data = data[:, None] if fields else data
            yield from _steps(data, sum(per_t.values()), t0, header)
            return
        for t in range(shape[0]):
            frame = reader.read(frame=t, workers=0).data
            spent = 1000.0 * (time.perf_counter() - t0)
            yield frame, FrameStats(t, "volume", per_t.get(t, 0), spent), header
            t0 = time.perf_counter()


def _four_d(shape: tuple[int, ...], source: str) -> None:
    if len(shape) != 4:
        raise FormatError(
            f"expected an animation, a 4-D (t, z, y, x) series or a netCDF variable (time, y, "
            f"x) to play, found a volume of shape {list(shape)} in {source} (to turn about "
            "it: volpack render SOURCE OUT_DIR --orbit N)"
        )


def _steps(data: np.ndarray, nbytes: int, t0: float, header: dict):
    """The time steps of a series decoded whole: the decode counted in the first step."""
    spent = 1000.0 * (time.perf_counter() - t0)
    for t in range(data.shape[0]):
        yield data[t], FrameStats(t, "volume", nbytes // data.shape[0], spent), header
        spent = 0.0


def play_rendered(
    source: Any, render: Callable[[np.ndarray], np.ndarray]
) -> Iterator[tuple[np.ndarray, FrameStats]]:
    """Yield ``(image, stats)`` per displayed frame: :func:`play`, then ``render(frame)``
    timed into ``stats.render_ms``."""
    for frame, st, _ in play(source):
        t0 = time.perf_counter()
        img = render(frame)
        st.render_ms = 1000.0 * (time.perf_counter() - t0)
        yield img, st
