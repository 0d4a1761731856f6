"""What the ray caster computes once per volume and keeps across frames.

:func:`prepare_volume` turns a volume into a :class:`PreparedVolume`: the array the ray
caster samples (stored as it is for uint8, int8, uint16, int16 and float32, so an 8-bit
MRI is read as 8-bit, else a float32 copy), the mask of non-finite or masked voxels and
the finite value range. Pass it to :func:`volpack.render.raycast.render` in place of the
volume and each frame of an orbit reuses what the first one built:

* the per-voxel gradient volume (:func:`gradient_volume`, for shading), built on first
  use when it fits :data:`GRADIENT_BUDGET` bytes, else the renderer takes central
  differences on the fly (six more trilinear samples per shaded segment);
* the quantised normals (:mod:`volpack.render.normals`, 2 bytes a voxel, same budget)
  that orthographic shaded frames light through a table instead;
* the value range of every 8^3 brick (the empty-space test only redoes the
  transfer-function part per frame);
* the filled copy when non-finite voxels are replaced (the fill value depends on the
  transfer function; one filled copy is kept).

The gradient is the central difference of the voxels, ``v[i + 1] - v[i - 1]`` per axis
with the index clamped at the edges: trilinear interpolation of it equals the central
difference (one voxel either way) of the trilinear field at every position inside
``[0, n - 1]``, which is what the renderer computes without it. It is stored as int16
(6 bytes a voxel) when the data are integers whose range fits 32767 (exact), else as
float32 (12 bytes a voxel). A 256^3 8-bit MRI needs 100 MB; the default budget (1 GiB)
holds 179 M voxels of int16 gradients (about 560^3) or 89 M of float32 (about 450^3);
a 1024^3 volume renders with on-the-fly gradients.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._jit import kernel, read_only
from ..errors import VolpackError
from ..parallel import ordered_map
from ..volume import require_voxels
from .normals import NormalCodes

#: Bytes the per-voxel gradient volume may take (see the module docstring).
GRADIENT_BUDGET = 1 << 30
#: dtypes the ray caster samples as they are stored.
SAMPLED = (np.uint8, np.int8, np.uint16, np.int16, np.float32)
_UNSET = object()


@dataclasses.dataclass(eq=False)
class PreparedVolume:
    """A volume ready for repeated rendering (see the module docstring)."""

    data: np.ndarray  # C-contiguous (z, y, x), a dtype of SAMPLED
    spacing: tuple[float, float, float]
    bad: np.ndarray | None  # non-finite or masked voxels (None: there are none)
    finite_range: tuple[float, float] | None  # None: no finite voxel
    gradient_budget: int = GRADIENT_BUDGET
    # (fill value, what was built for it); one entry each bounds the memory
    _fill: tuple = (_UNSET, None)  # the filled array
    _grad: tuple = (_UNSET, None)  # the gradient volume, or False over the budget
    _ranges: tuple = (_UNSET, None)  # (key, (mins, maxs) per brick, kernel)
    _leap: tuple = (None, None)  # (empty bricks, leap map)
    _codes: tuple = (_UNSET, None)  # quantised normals (NormalCodes), or False over the budget
    _memo: dict = dataclasses.field(default_factory=dict)  # name -> (key, value, boxes)
    # a zeroed uint16 array of the data's shape the first quantised normals take as
    # theirs (a walk's, made beforehand: render.resident.Reserved), or None
    codes_out: np.ndarray | None = None

    @property
    def shape(self) -> tuple[int, int, int]:
        return tuple(int(n) for n in self.data.shape)

    def filled(self, fill: float | None) -> np.ndarray:
        """The sampled array with the bad voxels set to ``fill`` (the array itself when
        there are none)."""
        if self.bad is None:  # read-only whoever owns it: one signature (_jit.read_only)
            return read_only(self.data)
        if self._fill[0] != fill:
            dt = self.data.dtype
            ok = dt.kind == "f" or (float(fill).is_integer() and np.can_cast(
                np.min_scalar_type(int(fill)), dt))  # fmt: skip
            arr = self.data.astype(dt if ok else np.float32)
            arr[self.bad] = fill
            self._fill = (fill, read_only(arr))
        return self._fill[1]

    def gradients(self, fill: float | None, workers: int = 1) -> np.ndarray | None:
        """The per-voxel gradient volume of :meth:`filled`, or None over the budget."""
        if self._grad[0] != fill:
            vol = self.filled(fill)
            dt = gradient_dtype(vol, self.finite_range)
            need = vol.size * 3 * np.dtype(dt).itemsize
            g = gradient_volume(vol, dt, workers) if need <= self.gradient_budget else False
            self._grad = (fill, g)
        g = self._grad[1]
        return None if g is False else g

    def normal_codes(self, fill: float | None, spacing):
        """The quantised normals of :meth:`filled` at ``spacing``
        (:class:`volpack.render.normals.NormalCodes`, filled in on demand), or None when
        their 2 bytes a voxel would pass the gradient budget."""
        key = (fill, tuple(spacing))
        if self._codes[0] != key:
            vol = self.filled(fill)
            ok = vol.size * 2 <= self.gradient_budget
            out, self.codes_out = self.codes_out, None
            self._codes = (key, NormalCodes(vol, spacing, out) if ok else False)
        c = self._codes[1]
        return None if c is False else c

    def brick_ranges(self, fill: float | None, brick: int, kernel_fn) -> tuple:
        """Min and max per brick of :meth:`filled` (``kernel_fn`` fills them; it is kept
        to redo the bricks of :meth:`rewritten` boxes)."""
        if self._ranges[0] != (fill, brick):
            vol = self.filled(fill)
            nb = tuple(max(1, -(-s // brick)) for s in vol.shape)
            mins = np.empty(nb, np.float32)
            maxs = np.empty(nb, np.float32)
            kernel_fn(vol, brick, mins, maxs)
            self._ranges = ((fill, brick), (mins, maxs), kernel_fn)
        return self._ranges[1]

    def memo(self, name: str, key, build, refresh=None):
        """``build()``, kept under ``name`` (one value a name) while ``key`` stays equal.
        After :meth:`rewritten`, ``refresh(value, boxes)`` updates the kept value over
        the boxes of bricks whose ranges changed (without it the value is rebuilt)."""
        kept = self._memo.get(name)
        if kept is None or kept[0] != key or (kept[2] and refresh is None):
            kept = (key, build(), [])
            self._memo[name] = kept
        elif kept[2]:
            refresh(kept[1], kept[2])
            kept[2].clear()
        return kept[1]

    def rewritten(self, boxes) -> None:
        """The voxels of ``data`` in ``boxes`` (three slices each) were written anew (a
        walk's resident volume, :mod:`volpack.render.resident`): redo what was built
        from them there only. Brick ranges are redone for the bricks whose range reads
        the boxes, and memos told which bricks (see :meth:`memo`); quantised normals are
        redone later only for the chunks the boxes reach (one voxel around them:
        central differences), gradients now for those boxes and one voxel around them."""
        if not boxes:
            return
        self._fill = (_UNSET, None)
        n = self.data.shape
        if self._ranges[0] is not _UNSET and self.bad is None:
            brick = self._ranges[0][1]
            (mins, maxs), fn = self._ranges[1], self._ranges[2]
            bricks = []
            for b in boxes:  # a brick's range holds one voxel past its high side
                bb = tuple(slice(max(s.start - 1, 0) // brick, -(-s.stop // brick)) for s in b)
                sub = self.data[tuple(slice(t.start * brick, min(t.stop * brick + 1, m))
                                      for t, m in zip(bb, n))]  # fmt: skip
                shape = tuple(t.stop - t.start for t in bb)
                lo, hi = np.empty(shape, np.float32), np.empty(shape, np.float32)
                fn(np.ascontiguousarray(sub), brick, lo, hi)
                mins[bb], maxs[bb] = lo, hi
                bricks.append(bb)
            for kept in self._memo.values():
                kept[2].extend(bricks)
        else:
            self._ranges = (_UNSET, None)
            self._memo.clear()
        grown = [tuple(slice(max(s.start - 1, 0), min(s.stop + 1, m)) for s, m in zip(b, n))
                 for b in boxes]  # fmt: skip
        codes = self._codes[1]
        if codes:
            for b in grown:
                codes.stale(b)
        g = self._grad[1]
        if g is not None and g is not False and self.bad is None:
            for gb in grown:  # the box's voxels and their neighbours' differences read them
                src = tuple(slice(max(s.start - 1, 0), min(s.stop + 1, m)) for s, m in zip(gb, n))
                inner = tuple(slice(s.start - t.start, s.stop - t.start) for s, t in zip(gb, src))
                g[gb] = gradient_volume(np.ascontiguousarray(self.data[src]), g.dtype)[inner]
        else:
            self._grad = (_UNSET, None)

    def leap_map(self, empty: np.ndarray, kernel_fn) -> np.ndarray:
        """The leap map (int32) of the empty-brick mask ``empty`` (``kernel_fn`` fills
        it); kept while later frames find the same bricks empty (an orbit, or a TF
        edit that does not change what is visible)."""
        if self._leap[0] is None or not np.array_equal(self._leap[0], empty):
            leap = np.zeros(empty.shape, np.int32)
            kernel_fn(np.ascontiguousarray(empty), leap)
            self._leap = (empty.copy(), leap)
        return self._leap[1]


def prepare_volume(volume, spacing=None, *, gradient_budget: int = GRADIENT_BUDGET):
    """A :class:`PreparedVolume` of ``volume`` (an array or a
    :class:`volpack.volume.Volume`; a PreparedVolume is returned as it is)."""
    if isinstance(volume, PreparedVolume):
        return volume
    data, mask, sp = unpack_volume(volume, spacing)
    if data.dtype == bool:
        data = data.view(np.uint8)
    dt = data.dtype if data.dtype.type in SAMPLED else np.float32
    arr = np.ascontiguousarray(data, dtype=np.dtype(dt).newbyteorder("="))
    bad = ~np.isfinite(arr) if arr.dtype.kind == "f" else None
    if mask is not None:
        bad = mask.copy() if bad is None else (bad | mask)
    if bad is not None and not bad.any():
        bad = None
    finite = arr if bad is None else arr[~bad]
    rng = (float(finite.min()), float(finite.max())) if finite.size else None
    if not (isinstance(gradient_budget, (int, np.integer)) and gradient_budget >= 0):
        raise VolpackError(f"expected a gradient budget in bytes >= 0, found {gradient_budget!r}")
    return PreparedVolume(arr, sp, bad, rng, int(gradient_budget))


def gradient_dtype(vol: np.ndarray, value_range) -> type:
    """int16 when the differences of integer voxels fit it exactly, else float32."""
    if vol.dtype.kind in "iu" and value_range is not None:
        if value_range[1] - value_range[0] <= 32767:
            return np.int16
    return np.float32


def gradient_volume(vol: np.ndarray, dtype=np.float32, workers: int = 1) -> np.ndarray:
    """Central differences ``(nz, ny, nx, 3)`` of ``vol`` along (z, y, x), edges clamped
    (see the module docstring); slabs of z on ``workers`` threads."""
    out = np.empty((*vol.shape, 3), dtype)
    vol = read_only(vol)  # one compiled signature for every caller
    nz = vol.shape[0]
    chunk = max(1, math.ceil(nz / max(1, 4 * workers)))
    starts = list(range(0, nz, chunk))
    for _ in ordered_map(
        lambda z0: _gradient_kernel(vol, z0, min(z0 + chunk, nz), out), starts, workers=workers
    ):
        pass
    return out


@kernel
def _gradient_kernel(vol, z0, z1, out):
    nz, ny, nx = vol.shape
    for z in range(z0, z1):
        zm, zp = max(z - 1, 0), min(z + 1, nz - 1)
        for y in range(ny):
            ym, yp = max(y - 1, 0), min(y + 1, ny - 1)
            for x in range(nx):
                xm, xp = max(x - 1, 0), min(x + 1, nx - 1)
                # in float64: unsigned differences would wrap
                out[z, y, x, 0] = np.float64(vol[zp, y, x]) - np.float64(vol[zm, y, x])
                out[z, y, x, 1] = np.float64(vol[z, yp, x]) - np.float64(vol[z, ym, x])
                out[z, y, x, 2] = np.float64(vol[z, y, xp]) - np.float64(vol[z, y, xm])


def unpack_volume(volume, spacing):
    """``(array, mask or None, spacing)`` of an array or a :class:`volpack.volume.Volume`,
    checked (3-D, non-empty, real numbers, three finite spacings > 0)."""
    mask = None
    sp = spacing
    if hasattr(volume, "data") and hasattr(volume, "spacing"):
        if volume.data.ndim != 3:
            raise VolpackError(
                f"expected a 3-D (z, y, x) volume, found shape {volume.data.shape}; "
                "pick one time step first"
            )
        mask = volume.mask
        if sp is None:
            sp = volume.spacing
        volume = volume.data
    data = np.asarray(volume)
    if data.ndim != 3:
        raise VolpackError(f"expected a 3-D (z, y, x) array, found shape {data.shape}")
    require_voxels(data.shape)
    if not (np.issubdtype(data.dtype, np.number) or data.dtype == bool):
        raise VolpackError(f"expected numeric voxels, found dtype {data.dtype}")
    if np.iscomplexobj(data):
        raise VolpackError(f"expected real voxels, found dtype {data.dtype}")
    sp = (1.0, 1.0, 1.0) if sp is None else tuple(float(s) for s in sp)
    if len(sp) != 3 or not all(math.isfinite(s) and s > 0 for s in sp):
        raise VolpackError(f"expected three finite spacings > 0, found {sp}")
    return data, (None if mask is None else np.asarray(mask, bool)), sp
