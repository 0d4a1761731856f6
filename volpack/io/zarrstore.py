"""zarr stores (format 2 or 3, OME-Zarr included) through zarr-python (``zarr`` extra):
``store.zarr`` or ``store.zarr:/path/to/array``.

A store holding one array, or an OME-Zarr image, needs no path: the image's first
(finest) multiscale level is read, with its ``scale`` and ``translation`` as spacing and
origin; name another level (``img.zarr:/2``) to read that one. Axes of length 1 in front
(a single time point or channel) are dropped; what is left must be 2-D, 3-D (z, y, x) or
4-D (t, z, y, x). The octree builder reads such an array box by box. Written as an
OME-Zarr 0.5 image of one level (zarr format 3, chunks of up to 64 voxels a side, zarr's
default compression), so that viewers place it with its spacing and origin.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import FormatError
from ..volume import Volume
from .common import (
    ReadOptions,
    check_voxels,
    field_shape,
    header_dict,
    meta_json,
    native,
    origin3,
    spacing3,
    stored_meta,
    to_volume,
)


def _library():
    try:
        import zarr
    except ImportError:
        raise FormatError(
            "expected zarr to read a zarr store, found it missing: pip install 'volpack[zarr]'"
        ) from None
    return zarr


def _multiscales(attrs) -> list:
    """OME-Zarr's ``multiscales`` (0.5 keeps it under ``ome``, 0.4 at the top)."""
    ome = attrs.get("ome")
    found = ome.get("multiscales") if isinstance(ome, dict) else attrs.get("multiscales")
    return found if isinstance(found, list) else []


def _transforms(group, name: str, ndim: int) -> tuple[tuple, tuple]:
    """The spacing and origin an OME-Zarr ``group`` gives its level ``name`` (z, y, x:
    the last three axes), or ones and zeros."""
    scale, shift = [1.0] * ndim, [0.0] * ndim
    for ms in _multiscales(group.attrs if group is not None else {}):
        for level in ms.get("datasets", []) if isinstance(ms, dict) else []:
            if not isinstance(level, dict) or level.get("path") != name:
                continue
            for t in level.get("coordinateTransformations", []):
                if t.get("type") == "scale" and len(t.get("scale", [])) == ndim:
                    scale = [float(s) * a for s, a in zip(t["scale"], scale)]
                elif t.get("type") == "translation" and len(t.get("translation", [])) == ndim:
                    shift = [float(s) + b for s, b in zip(t["translation"], shift)]
    return spacing3(scale[-3:]), origin3(shift[-3:])


def _root(path: str):
    """zarr-python and the store's top node (an array or a group), opened to read."""
    zarr = _library()
    return zarr, zarr.open(store=path, mode="r")


def _pick(path: str, inner: str | None):
    """The array to read, the group holding it and its name there."""
    zarr, root = _root(path)
    if inner:
        name = inner.strip("/")
        try:
            node = root[name] if isinstance(root, zarr.Group) else None
        except KeyError:
            node = None
        if not isinstance(node, zarr.Array):
            raise FormatError(f"expected an array {name!r} in the zarr store {path!r}, found none")
        parent, _, leaf = name.rpartition("/")
        return node, (root[parent] if parent else root), leaf
    if isinstance(root, zarr.Array):
        return root, None, ""
    for ms in _multiscales(root.attrs):
        levels = ms.get("datasets", []) if isinstance(ms, dict) else []
        if levels and isinstance(levels[0], dict) and levels[0].get("path") in root:
            return root[levels[0]["path"]], root, levels[0]["path"]
    arrays = [name for name, _ in root.arrays()]
    if len(arrays) == 1:
        return root[arrays[0]], root, arrays[0]
    raise FormatError(
        f"expected one array or an OME-Zarr image in {path!r} (name it as {path}:/path), "
        f"found {', '.join(arrays[:10]) or 'no array'} at its top"
    )


def arrays(path: str) -> list[dict[str, Any]]:
    """Every array of the store, at any depth: name, shape and dtype."""
    zarr, root = _root(path)
    if isinstance(root, zarr.Array):
        return [{"name": "/", "shape": list(root.shape), "dtype": str(root.dtype)}]
    return [
        {"name": "/" + name, "shape": list(node.shape), "dtype": str(node.dtype)}
        for name, node in sorted(root.members(max_depth=None))
        if isinstance(node, zarr.Array)
    ]


def open_array(path: str, inner: str | None):
    """(array, shape, spacing, origin, meta) of the array a spec names; the array reads
    lazily, by slices."""
    arr, group, name = _pick(path, inner)
    if np.dtype(arr.dtype).kind not in "biuf":
        raise FormatError(f"expected integer or float voxels in {path!r}, found {arr.dtype}")
    spacing, origin = _transforms(group, name, arr.ndim)
    meta = stored_meta(group.attrs if group is not None else arr.attrs, "zarr")
    meta["zarr_array"] = "/" + name if name else "/"
    return arr, field_shape(arr.shape, repr(path)), spacing, origin, meta


def read(path: str, opts: ReadOptions) -> Volume:
    arr, shape, spacing, origin, meta = open_array(path, opts.inner)
    check_voxels(shape, opts.max_voxels, path)
    return to_volume(arr[...], meta, path, shape, spacing, origin)


def header(path: str, opts: ReadOptions) -> dict[str, Any]:
    arr, shape, spacing, origin, meta = open_array(path, opts.inner)
    return header_dict("zarr", shape, native(arr.dtype), spacing, origin, meta)


def write(vol: Volume, path: str, force: bool, inner: str | None = None) -> None:
    from ..format.atomic import atomic_dir, interrupts_deferred

    if inner:
        raise FormatError(
            f"expected a whole zarr store as output ({path}), found an array path {inner!r} in it"
        )
    zarr = _library()
    data = vol.data
    lead = data.ndim - 3  # a time axis
    axes = [{"name": "t", "type": "time"}] * lead + [{"name": n, "type": "space"} for n in "zyx"]
    level = {
        "path": "0",
        "coordinateTransformations": [
            {"type": "scale", "scale": [1.0] * lead + [float(s) for s in vol.spacing]},
            {"type": "translation", "translation": [0.0] * lead + [float(o) for o in vol.origin]},
        ],
    }
    attrs: dict[str, Any] = {
        "ome": {"version": "0.5", "multiscales": [{"axes": axes, "datasets": [level]}]}
    }
    text = meta_json(vol)
    if text is not None:
        attrs["volpack_meta"] = text
    # Every call into zarr holds Ctrl-C back until it returns: zarr works in its own
    # event-loop thread, which an interrupt does not stop, so it would go on filling the
    # folder the interrupted write is removing. The voxels go a row of chunks at a time,
    # so that an interrupt waits for one row at most.
    with atomic_dir(path, force=force) as tmp:
        with interrupts_deferred():
            group = zarr.open_group(tmp, mode="w", zarr_format=3)
            chunks = (1,) * lead + tuple(min(64, int(n)) for n in data.shape[lead:])
            array = group.create_array("0", shape=data.shape, chunks=chunks, dtype=data.dtype)
        for i in range(0, data.shape[0], chunks[0]):
            with interrupts_deferred():
                array[i : i + chunks[0]] = data[i : i + chunks[0]]
        with interrupts_deferred():
            group.attrs.update(attrs)
