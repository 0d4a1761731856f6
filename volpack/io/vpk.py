"""volpack's own ``.vpk``: decoded (read) or coded losslessly (written) through the API."""

from __future__ import annotations

from ..volume import Volume
from .common import ReadOptions


def read(path: str, opts: ReadOptions) -> Volume:
    from .. import api

    return api.decompress(path, max_voxels=opts.max_voxels)


def write(vol: Volume, path: str, force: bool, inner: str | None = None) -> None:
    from .. import api

    api.compress(vol, path, force=force)
