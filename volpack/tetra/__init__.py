"""Tetrahedral meshes: the mesh model, cut-border connectivity coding, vertex and attribute
coding, and the ``.vpk`` mesh stream (seed-004 §3.3, digest §10).

Submodules are imported on use (most load numba): :mod:`.mesh` (model, checks),
:mod:`.formats` (meshio in and out), :mod:`.cutborder` (connectivity),
:mod:`.geometry` (coordinates), :mod:`.attributes` (point and cell data),
:mod:`.stream` (``compress_mesh``, ``decompress_mesh``, ``mesh_info``). This module
itself imports nothing heavy, so the command line can ask :func:`is_mesh_path` cheaply.
"""

from __future__ import annotations

import os

# Suffixes of the volume-mesh formats meshio reads (surface-only formats left out).
MESH_EXTENSIONS = (
    ".vtu", ".vtk", ".msh", ".mesh", ".meshb", ".xdmf", ".xmf", ".xml", ".inp", ".ele",
    ".node", ".med", ".vol", ".e", ".exo", ".ex2", ".h5m", ".avs", ".su2", ".ugrid",
    ".cgns", ".f3grid", ".mdpa", ".bdf", ".fem", ".nas", ".tec", ".hmf", ".post", ".dato",
)  # fmt: skip


def is_mesh_path(path: str) -> bool:
    """True when ``path`` names a volume-mesh format meshio reads (by its suffix)."""
    p = os.fspath(path).lower()
    if p.endswith(".gz"):
        p = p[:-3]
    return p.endswith(MESH_EXTENSIONS)
