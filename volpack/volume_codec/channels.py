"""4-D volumes whose last axis holds channels, ``(z, y, x, c)``: RGB, fluorescence.

Stored as the series of their channels ``(c, z, y, x)`` (each channel coded as a time
step is), the header saying ``"channels": "last"``; decoded as ``(z, y, x, c)`` again.
A light module (no kernels) so that ``volpack info`` of a source file names the axes as
``compress`` will take them.
"""

from __future__ import annotations

# A 4-D volume whose last axis has at most this many voxels (and every other more) is
# taken as (z, y, x, c) channels unless told otherwise (compress's ``channels_last``).
MAX_CHANNELS = 4
CHANNELS_LAST = "last"  # the header's "channels" value


def looks_channels_last(shape: tuple[int, ...]) -> bool:
    """Whether a 4-D shape reads as ``(z, y, x, c)``: a last axis of at most
    MAX_CHANNELS voxels (RGB, RGBA, two fluorescence channels) and more along every other
    (a series of volumes 4 voxels wide is not met in practice)."""
    return len(shape) == 4 and shape[-1] <= MAX_CHANNELS < min(shape[:-1])


def looks_channels_first(shape: tuple[int, ...]) -> bool:
    """Whether a 4-D shape may be ``(c, z, y, x)``: a first axis of at most MAX_CHANNELS
    voxels and more along every other. Such a volume stays a series (a time step a
    channel) unless its tuples make a palette (:mod:`.tuples`), which is lossless
    whatever the first axis means."""
    return len(shape) == 4 and shape[0] <= MAX_CHANNELS < min(shape[1:])
