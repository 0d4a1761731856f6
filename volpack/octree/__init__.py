"""Multiresolution octrees of large volumes (seed-004 §2.2.4 and §2.3, digest §7).

:func:`build` turns a volume (in memory, or a file read box by box) into a ``.vpk`` of
kind ``octree``; :class:`Octree` opens one for level-of-detail access; the selection
functions in :mod:`volpack.octree.select` choose which nodes to decode (by level, error,
region, budget or camera). The byte format is ``formats/octree-1.md``.
"""

from .build import build
from .layout import DEFAULT_BLOCK, KIND, Geometry
from .reader import NodeDamaged, Octree, parse_region

__all__ = ["DEFAULT_BLOCK", "KIND", "Geometry", "NodeDamaged", "Octree", "build", "parse_region"]
