"""Multiresolution octrees of large volumes (seed-004 §2.2.4 and §2.3, digest §7).

:func:`build` turns a volume (in memory, or a file read box by box) into a ``.vpk`` of
kind ``octree`` (:mod:`volpack.octree.builder`); :class:`Octree` opens one for
level-of-detail access; the selection functions in :mod:`volpack.octree.select` choose
which nodes to decode (by level, error, region, budget or camera). The byte format is
``formats/octree-1.md``.
"""

from .layout import DEFAULT_BLOCK, KIND, Geometry
from .reader import NodeDamaged, Octree, parse_region

__all__ = ["DEFAULT_BLOCK", "KIND", "Geometry", "NodeDamaged", "Octree", "build", "parse_region"]


def __getattr__(name: str):
    # the builder (its kernel, the metrics, the input readers) is imported on first
    # use: a reader's start does not need it (10 ms of a walk's, compiled from source)
    if name == "build":
        from .builder import build

        globals()["build"] = build
        return build
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
