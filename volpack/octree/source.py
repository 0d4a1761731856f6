"""Block sources: read any box of a volume without loading the volume.

The octree build reads its input one super-brick at a time, so the input must allow
random access to boxes: ``.npy`` and native-order ``.raw`` files are memory-mapped,
HDF5 datasets are sliced through h5py (chunked or contiguous), a multi-page TIFF is read
page range by page range and a folder of TIFF slices file by file. Anything else volpack
reads (NIfTI, NRRD, DICOM, ``.vpk``) is read whole, which is fine for volumes that fit in
memory. A source is described by a small picklable :class:`SourceSpec`, so a Dask worker
can open the same input itself instead of receiving voxels over the network.
"""

from __future__ import annotations

import dataclasses
import functools
import os
import threading
from typing import Any

import numpy as np

from ..errors import FormatError


@dataclasses.dataclass(frozen=True)
class SourceSpec:
    """How to open a volume: a path spec (``file.h5:/ds``) plus raw-file options."""

    spec: str
    raw: tuple[tuple[str, Any], ...] = ()


class ArraySource:
    """An in-memory (or memory-mapped) array as a block source."""

    def __init__(self, array: np.ndarray, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0)):
        self.array = array
        self.shape = tuple(int(n) for n in array.shape)
        self.dtype = np.dtype(array.dtype).newbyteorder("=")
        self.spacing = tuple(float(s) for s in spacing)
        self.origin = tuple(float(o) for o in origin)

    def read(self, box: tuple[slice, slice, slice]) -> np.ndarray:
        return np.ascontiguousarray(self.array[box], dtype=self.dtype)


class _H5Source:
    def __init__(self, path: str, inner: str | None):
        import h5py

        from ..io import hdf5

        self._file = h5py.File(path, "r")
        self._ds = hdf5.pick_dataset(self._file, inner, path)
        self.shape = tuple(int(n) for n in self._ds.shape)
        self.dtype = np.dtype(self._ds.dtype).newbyteorder("=")
        self.spacing, self.origin, _ = hdf5.geometry(self._ds)
        self._lock = threading.Lock()  # h5py serialises anyway; be explicit

    def read(self, box):
        with self._lock:
            return np.ascontiguousarray(self._ds[box], dtype=self.dtype)


class _TiffSource:
    """A multi-page TIFF (one page per z slice) or a folder of single-page slices."""

    def __init__(self, path: str):
        import tifffile

        from ..io import tiff
        from ..io.common import natural_key

        self._lock = threading.Lock()
        if os.path.isdir(path):
            names = sorted(
                (n for n in os.listdir(path) if n.lower().endswith((".tif", ".tiff"))),
                key=natural_key,
            )
            if not names:
                raise FormatError(f"expected .tif/.tiff slices in {path!r}, found none")
            self._files = [os.path.join(path, n) for n in names]
            with tifffile.TiffFile(self._files[0]) as tif:
                page = tif.series[0]
                yx = tuple(int(s) for s in page.shape)
                self.dtype = np.dtype(page.dtype).newbyteorder("=")
                ys, xs = tiff.xy_spacing(tif.pages[0])
            if len(yx) != 2:
                raise FormatError(f"expected 2-D slices in {path!r}, found shape {yx}")
            self.shape = (len(self._files), *yx)
            self.spacing, self.origin = (1.0, ys, xs), (0.0, 0.0, 0.0)
            self._tif = None
        else:
            self._tif = tifffile.TiffFile(path)
            shape, dtype, self.spacing, self.origin, _ = tiff.geometry(self._tif, path)
            if len(shape) != 3 or len(self._tif.pages) != shape[0]:
                raise FormatError(
                    f"expected a TIFF stack with one page per z slice in {path!r}, found "
                    f"shape {shape} in {len(self._tif.pages)} pages"
                )
            self.shape, self.dtype = shape, np.dtype(dtype)

    def read(self, box):
        import tifffile

        z = range(*box[0].indices(self.shape[0]))
        with self._lock:
            if self._tif is not None:
                planes = self._tif.asarray(key=list(z)).reshape(len(z), *self.shape[1:])
                return np.ascontiguousarray(planes[:, box[1], box[2]], dtype=self.dtype)
            out = [tifffile.imread(self._files[i])[box[1], box[2]] for i in z]
        return np.ascontiguousarray(np.stack(out), dtype=self.dtype)


class _FileSource:
    """A ``.npy`` or ``.raw`` file read row by row with ``pread`` (no memory map, so the
    process's resident memory stays the boxes it holds, whatever the file size)."""

    def __init__(self, path: str, shape, dtype: np.dtype, offset: int, spacing, origin):
        self._fd = os.open(path, os.O_RDONLY)
        self.shape = tuple(int(n) for n in shape)
        self._file_dtype = np.dtype(dtype)
        self.dtype = self._file_dtype.newbyteorder("=")
        self._offset = int(offset)
        self.spacing, self.origin = spacing, origin

    def read(self, box):
        z, y, x = (range(*s.indices(n)) for s, n in zip(box, self.shape))
        item = self._file_dtype.itemsize
        ny, nx = self.shape[1], self.shape[2]
        out = np.empty((len(z), len(y), len(x)), self._file_dtype)
        nbytes = len(x) * item
        for i, zi in enumerate(z):
            for j, yj in enumerate(y):
                pos = self._offset + ((zi * ny + yj) * nx + x.start) * item
                row = os.pread(self._fd, nbytes, pos)
                if len(row) != nbytes:
                    raise FormatError(f"expected {nbytes} bytes at offset {pos}, found {len(row)}")
                out[i, j] = np.frombuffer(row, self._file_dtype)
        return out.astype(self.dtype, copy=False)

    def __getstate__(self):
        raise TypeError("a file source is opened where it is used; pass its SourceSpec")


def open_source(source: Any) -> Any:
    """Return a block source (``shape``, ``dtype``, ``spacing``, ``origin``, ``read(box)``).

    ``source`` is an ndarray, a :class:`~volpack.volume.Volume`, a block source, or a
    :class:`SourceSpec` / path spec.
    """
    from ..volume import Volume

    if isinstance(source, Volume):
        return ArraySource(source.data, source.spacing, source.origin)
    if isinstance(source, np.ndarray):
        return ArraySource(source)
    if isinstance(source, str):
        source = SourceSpec(source)
    if isinstance(source, SourceSpec):
        return _open_spec(source)
    if hasattr(source, "read") and hasattr(source, "shape"):
        return source
    raise TypeError(
        f"expected an array, a Volume, a path or a SourceSpec, found {type(source).__name__}"
    )


@functools.lru_cache(maxsize=8)
def _open_spec(s: SourceSpec):
    """One open source per spec and process (Dask workers reuse it across tasks)."""
    from .. import io as vio
    from ..io import raw as raw_io
    from ..io.common import ReadOptions, wrap_errors

    path, inner = vio.parse_spec(s.spec)
    if path == "-":
        raise FormatError("expected a file for the octree build (it reads boxes), found '-'")
    raw = dict(s.raw)
    given = raw.get("shape") is not None or raw.get("dtype") is not None
    fmt = "raw" if given and not os.path.isdir(path) else vio.detect_format(path)
    if fmt == "hdf5":
        with wrap_errors(fmt, path):
            return _H5Source(path, inner)
    if fmt == "zarr":  # read box by box, as zarr reads chunks
        from ..io import zarrstore

        with wrap_errors(fmt, path):
            arr, _, spacing, origin, _ = zarrstore.open_array(path, inner)
        if arr.ndim == 3:
            return ArraySource(arr, spacing, origin)
    if fmt in ("tiff", "tiff-folder"):
        with wrap_errors(fmt, path):
            return _TiffSource(path)
    if fmt == "npy":
        with open(path, "rb") as f:
            fmt_ = np.lib.format
            v1 = fmt_.read_magic(f) == (1, 0)
            hdr = fmt_.read_array_header_1_0 if v1 else fmt_.read_array_header_2_0
            shape, fortran, dtype = hdr(f)
            offset = f.tell()
        if len(shape) == 3 and not fortran and np.dtype(dtype).kind in "biuf":
            return _FileSource(path, shape, dtype, offset, (1.0,) * 3, (0.0,) * 3)
    if fmt == "raw":
        with wrap_errors(fmt, path):
            sh, dt = raw_io.layout(ReadOptions(None, **raw), os.path.getsize(path), path)
        if len(sh) == 3:
            return _FileSource(path, sh, dt, raw.get("offset", 0), (1.0,) * 3, (0.0,) * 3)
    vol = vio.read_volume(s.spec, **raw)  # other formats: read whole
    return ArraySource(vol.data, vol.spacing, vol.origin)
