"""The stream kinds of ``.vpk`` files, registered by the header's ``kind``.

Each kind is a module providing the same five calls:

* ``compress(source, target, **options) -> dict``: code ``source`` into ``target`` and
  return what was measured (a path ``source`` is read by the kind, after ``target`` has
  been checked, so that a refusal costs nothing);
* ``open(source) -> reader``: a context manager with the checked ``header``;
* ``decompress(source, **options)``: the decoded object (a Volume; a TetMesh for meshes);
* ``check_header(header) -> header``: raise :class:`~volpack.errors.FormatError` unless it
  is a valid header of this kind;
* ``info(source) -> dict``: what the file holds, as JSON types.

Modules are imported on first use: importing all four loads every numba kernel module of
volpack (about a second), and most calls need one.
"""

from __future__ import annotations

import importlib
from types import ModuleType
from typing import Any

from .errors import FormatError

KINDS = {
    "volume": "volpack.volume_codec.stream",
    "animation": "volpack.animation.stream",
    "octree": "volpack.octree.stream",
    "mesh": "volpack.tetra.stream",
}


def get_kind(kind: str) -> ModuleType:
    """The module of stream kind ``kind`` (a header's ``kind``)."""
    name = KINDS.get(kind) if isinstance(kind, str) else None
    if name is None:
        raise FormatError(f"expected a stream kind among {', '.join(KINDS)}, found {kind!r}")
    return importlib.import_module(name)


def choose(source: Any, options: dict) -> str:
    """The kind :func:`volpack.api.compress` makes of ``source`` when none is named: a mesh
    for a TetMesh or a mesh file, an animation when ``gop`` is given or ``source`` is a glob
    pattern of frame files, else a volume."""
    from .tetra import is_mesh_path

    if isinstance(source, str):
        if source != "-" and is_mesh_path(source):
            return "mesh"
        if any(c in source for c in "*?["):
            return "animation"
    else:
        from .tetra.mesh import TetMesh

        if isinstance(source, TetMesh):
            return "mesh"
    if options.get("gop_string") is not None:
        return "animation"
    return "volume"
