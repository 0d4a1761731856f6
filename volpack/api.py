"""The library calls behind ``volpack compress``, ``decompress`` and ``info``: a dispatcher
over the stream kinds (:mod:`volpack.kinds`).

A ``.vpk`` file says its kind in its header (``volume``, ``animation``, ``octree``,
``mesh``); decoding and describing a file go to that kind's module. Compressing picks the
kind from ``kind=`` or from the source (:func:`volpack.kinds.choose`). The volume kind,
which the array helpers use, is :mod:`volpack.volume_codec.stream`.
"""

from __future__ import annotations

import io as _io
import os
from typing import Any, BinaryIO

import numpy as np

from .errors import FormatError, OptionError, reading
from .kinds import choose, get_kind
from .volume import Volume


def compress(source: Any, target: str | BinaryIO, *, kind: str | None = None, **options: Any):
    """Compress ``source`` into the ``.vpk`` file or stream ``target``; return what was
    measured. ``kind`` (default: :func:`volpack.kinds.choose`) names the stream kind whose
    ``compress`` takes the options: for volumes (arrays, Volumes, volume files) see
    :func:`volpack.volume_codec.stream.compress`, for animations
    :func:`volpack.animation.stream.compress`, for octrees
    :func:`volpack.octree.stream.compress`, for meshes :func:`volpack.tetra.stream.compress`.
    A ``.vpk`` volume file as ``source`` is decoded first (recompression)."""
    kind = kind or choose(source, options)
    if kind == "volume" and isinstance(source, str) and kind_of(source) is not None:
        from .format.atomic import check_output

        check_output(target, force=options.get("force", False), inputs=(source,))
        options.pop("read_options", None)
        source = read_volume(source)
    return get_kind(kind).compress(source, target, **options)


def kind_of(source: Any) -> str | None:
    """The stream kind of a ``.vpk`` path (or ``'-'``, peeked at without consuming it);
    None when it is not a ``.vpk``."""
    from .format.streams import vpk_kind

    if not isinstance(source, (str, os.PathLike)):
        return None
    try:
        return vpk_kind(os.fspath(source))
    except (OSError, FormatError):
        return None


def open(source: Any, **options: Any):  # noqa: A001
    """Open a ``.vpk`` with the reader of its kind (see :mod:`volpack.kinds`)."""
    return get_kind(_header_kind(source)).open(source, **options)


def decompress(source: str | bytes | BinaryIO, **options: Any):
    """Decode a ``.vpk`` (a path, ``'-'`` for standard input, bytes or a binary file) with
    its kind's ``decompress``. For volumes and animations: ``roi`` (``"z0:z1,y0:y1,x0:x1"``
    or three slices; only the bricks it touches are read), ``frame`` (one time step),
    ``workers``, ``progress``, ``max_voxels``; the result is a
    :class:`~volpack.volume.Volume` keeping dtype, spacing and the region's origin. Octrees
    take ``level`` or ``error``; meshes decode to a :class:`~volpack.tetra.mesh.TetMesh`."""
    from .format.container import Reader

    if isinstance(source, (str, os.PathLike)) and source != "-":
        with reading(source):  # a damaged chunk's error names the file too
            return get_kind(_header_kind(source)).decompress(source, **options)
    if isinstance(source, str):
        from .format.streams import stdin

        source = stdin()
    r = Reader(source)  # the kind's reader takes it over and closes it
    try:
        mod = get_kind(r.header.get("kind"))
    except BaseException:
        r.close()
        raise
    return mod.decompress(r, **options)


def compress_array(array: np.ndarray | Volume, **options: Any) -> bytes:
    """Compress an array (or a Volume) to ``.vpk`` bytes (options as for the volume kind's
    :func:`~volpack.volume_codec.stream.compress`)."""
    from .volume_codec.stream import compress as compress_volume

    buf = _io.BytesIO()
    compress_volume(array if isinstance(array, Volume) else np.asarray(array), buf, **options)
    return buf.getvalue()


def decompress_array(blob: bytes, **options: Any) -> np.ndarray:
    """Decode ``.vpk`` bytes made by :func:`compress_array` back to the array."""
    return read_volume_from(bytes(blob), **options).data


def read_volume_from(source: Any, **options: Any) -> Volume:
    """Decode a ``.vpk`` that must hold a volume (of kind volume, animation or octree)."""
    out = decompress(source, **options)
    if not isinstance(out, Volume):
        raise FormatError(f"expected a .vpk of a volume, found a {type(out).__name__}")
    return out


def info(source: str | bytes | BinaryIO, **read_options: Any) -> dict[str, Any]:
    """Describe a ``.vpk`` file (a path, its bytes, or a seekable binary file such as
    :func:`volpack.format.streams.spool` of a pipe) through its kind's ``info``, a mesh file
    (its report), or any volume volpack reads, as plain JSON types."""
    from . import io as vio

    if isinstance(source, (bytes, bytearray, memoryview)):
        source = _io.BytesIO(bytes(source))
    if not isinstance(source, str) or (source != "-" and kind_of(source) is not None):
        with reading(source if isinstance(source, str) else None):
            return get_kind(_header_kind(source)).info(source)
    from .tetra import is_mesh_path

    if source != "-" and is_mesh_path(source):
        from .tetra.formats import describe_mesh_file

        return describe_mesh_file(source)
    vol = vio.read_volume(source, **read_options)
    d = vol.describe()
    d["format"] = vio.detect_format(vio.parse_spec(source)[0]) if source != "-" else "npy"
    d["path"] = source
    return d


def read_volume(spec: str, **read_options: Any) -> Volume:
    """Read a volume from any file volpack reads (:func:`volpack.io.read_volume`), a
    ``.vpk`` of a volume, an animation or an octree included."""
    from . import io as vio

    path = vio.parse_spec(spec)[0] if spec != "-" else spec
    if kind_of(path) is not None:  # a .vpk file, or a .vpk stream on standard input
        keep = {k: v for k, v in read_options.items() if k == "max_voxels"}
        return read_volume_from(path, **keep)
    return vio.read_volume(spec, **read_options)


def write_volume(vol: Volume | np.ndarray, spec: str, *, force: bool = False) -> None:
    """Write a volume to any file volpack writes (:func:`volpack.io.write_volume`); a
    ``.vpk`` path is compressed losslessly."""
    from . import io as vio

    if spec != "-" and vio.output_format(vio.parse_spec(spec)[0]) == "vpk":
        from .volume_codec.stream import compress as compress_volume

        compress_volume(vol if isinstance(vol, Volume) else np.asarray(vol), spec, force=force)
        return
    vio.write_volume(vol, spec, force=force)


def check_vpk_name(path: str, what: str = "an output", why: str = "a .vpk") -> None:
    """Refuse to write a ``.vpk`` under the name of another format (``ct.nii.gz``,
    ``m.vtu``): every other program would then fail on it. A name of no known format
    (``out``, ``x.txt``) is taken."""
    from .io.registry import extensions, parse_spec
    from .tetra import is_mesh_path

    p = parse_spec(path)[0]
    named = [f for e, f in extensions().items() if p.lower().endswith(e) and f != "vpk"]
    if named or (p != "-" and is_mesh_path(p)):
        raise OptionError(
            f"expected {what} ending in .vpk ({why}; 'volpack convert' writes the others), "
            f"found {path!r}"
        )


def refuse_other_format(path: str) -> None:
    """A file of another format by its name and first bytes ('volpack decompress ct.npy'):
    say so, rather than which magic bytes the container expected."""
    from .format.container import MAGIC
    from .io.registry import detect_format

    try:
        with _io.open(path, "rb") as f:  # this module's open() is volpack.open
            head = f.read(len(MAGIC))
        fmt = detect_format(path)
    except (OSError, FormatError):
        return  # the container's own error follows
    if len(head) == len(MAGIC) and head != MAGIC and fmt != "vpk":
        raise FormatError(
            f"expected a .vpk file, found the {fmt} file {path!r} (volpack convert and "
            "volpack compress read it)"
        )


def _header_kind(source: Any) -> str:
    """The ``kind`` in the header of a ``.vpk`` path, bytes or seekable binary file."""
    from .format.container import Reader

    if isinstance(source, (str, os.PathLike)) and source != "-":
        kind = kind_of(source)
        if kind is None:  # not a .vpk: let the container say what is wrong
            refuse_other_format(os.fspath(source))
            with Reader(source) as r:
                return r.header.get("kind")
        return kind
    if hasattr(source, "seek") and hasattr(source, "tell"):
        pos = source.tell()
        try:
            with Reader(source) as r:
                return r.header.get("kind")
        finally:
            source.seek(pos)
    with Reader(source) as r:
        return r.header.get("kind")
