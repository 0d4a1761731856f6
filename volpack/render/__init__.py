"""The reference renderer: transfer functions, pre-integration tables, cameras, ray casting.

Modules (import the one you need; importing this package loads neither numba nor any
submodule):

``volpack.render.transfer``
    :class:`~volpack.render.transfer.TransferFunction` (piecewise-linear RGBA over data
    values), JSON files, presets and the automatic choice. Pure numpy.
``volpack.render.preint``
    Pre-integration tables for linear ray segments (fast integral-function method and
    exact self-attenuating method), opacity correction and isosurface tables. numba.
``volpack.render.camera``
    Viewing parameters and ray generation.
``volpack.render.raycast``
    The CPU ray caster that composites table entries front to back.
"""
