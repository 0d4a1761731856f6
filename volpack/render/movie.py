"""Frame sequences out: MP4 (H.264 through imageio-ffmpeg's bundled ffmpeg), animated GIF
(Pillow) or a folder of numbered PNGs, chosen by the target's name.

Every kind appears whole or not at all: MP4 and GIF go to a temporary file beside the
target that is renamed when the writer closes without error; PNGs are written one by one,
each atomically, into the folder (a failure leaves the frames already written). Frames are
pre-multiplied RGBA images from the ray casters, composited over black; odd sizes are
padded with one black row or column for MP4, whose 4:2:0 colour needs even sizes.
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import VolpackError
from ..format.atomic import atomic_path, check_output
from .image import save_rgb8, to_rgb8

KINDS = ("mp4", "gif", "png")


def movie_kind(target: str) -> str:
    """``mp4``, ``gif`` or ``png`` (a folder: a trailing slash, an existing folder, or a
    name without an extension)."""
    t = os.fspath(target)
    ext = os.path.splitext(t.rstrip("/"))[1].lower()
    if t.endswith("/") or os.path.isdir(t) or ext == "":
        return "png"
    if ext in (".mp4", ".m4v"):
        return "mp4"
    if ext == ".gif":
        return "gif"
    raise VolpackError(f"expected an .mp4 or .gif file or a folder for the frames, found {t!r}")


class MovieWriter:
    """Write frames to ``target`` (see :func:`movie_kind`) at ``fps`` frames per second.

    >>> with MovieWriter("run.mp4", fps=25) as mw:
    ...     for img in images:
    ...         mw.write(img)

    ``quality`` is ffmpeg's 0-10 scale for MP4 (10 best). ``force`` replaces an existing
    file (for a folder: existing frames of the same names).
    """

    def __init__(self, target, *, fps: float = 25.0, quality: float = 8.0, force: bool = False):
        if not (np.isfinite(fps) and 0 < fps <= 1000):
            raise VolpackError(f"expected 0 < fps <= 1000, found {fps}")
        self.target = os.fspath(target)
        self.kind = movie_kind(self.target)
        self.fps = float(fps)
        self.quality = float(quality)
        self.force = force
        self.count = 0
        self._size = None
        self._gif: list = []
        self._ctx = None
        self._gen = None
        if self.kind == "png":
            os.makedirs(self.target, exist_ok=True)
        else:
            check_output(self.target, force=force)
            self._ctx = atomic_path(self.target, force=force, suffix="." + self.kind)
            self._tmp = self._ctx.__enter__()

    def path_of(self, k: int) -> str:
        """The PNG written for frame ``k`` (folder targets)."""
        return os.path.join(self.target, f"frame_{k:05d}.png")

    def write(self, rgba: np.ndarray) -> None:
        """Append one ``(h, w, 4)`` pre-multiplied frame (all frames one size)."""
        rgb = to_rgb8(rgba)
        if self._size is None:
            self._size = rgb.shape[:2]
        elif rgb.shape[:2] != self._size:
            raise VolpackError(f"expected frames of {self._size}, found {rgb.shape[:2]}")
        if self.kind == "png":
            save_rgb8(self.path_of(self.count), rgb, force=self.force)
        elif self.kind == "gif":
            from PIL import Image

            self._gif.append(Image.fromarray(rgb, "RGB"))
        else:
            self._mp4(rgb)
        self.count += 1

    def _mp4(self, rgb: np.ndarray) -> None:
        h, w = rgb.shape[:2]
        ph, pw = h + h % 2, w + w % 2
        if (ph, pw) != (h, w):
            pad = np.zeros((ph, pw, 3), np.uint8)
            pad[:h, :w] = rgb
            rgb = pad
        if self._gen is None:
            try:
                import imageio_ffmpeg
            except ImportError:
                raise VolpackError(
                    "MP4 output needs imageio-ffmpeg: pip install 'volpack[video]' "
                    "(or write a .gif or a folder of PNGs)"
                ) from None
            self._gen = imageio_ffmpeg.write_frames(
                self._tmp, (pw, ph), fps=self.fps, quality=self.quality,
                macro_block_size=1, ffmpeg_log_level="error", output_params=["-f", "mp4"],
            )  # fmt: skip
            self._gen.send(None)
        self._gen.send(np.ascontiguousarray(rgb).tobytes())

    def close(self) -> None:
        """Finish the file (MP4/GIF are renamed onto the target here)."""
        if self._ctx is None:
            return
        ctx, self._ctx = self._ctx, None
        try:
            if self.count == 0:
                raise VolpackError("expected at least one frame, found none")
            if self.kind == "gif":
                first, *rest = self._gif
                first.save(self._tmp, format="GIF", save_all=True, append_images=rest,
                           duration=max(1, round(1000 / self.fps)), loop=0)  # fmt: skip
            elif self._gen is not None:
                gen, self._gen = self._gen, None
                gen.close()
        except BaseException as e:
            ctx.__exit__(type(e), e, e.__traceback__)
            raise
        ctx.__exit__(None, None, None)

    def abort(self) -> None:
        """Drop a partial MP4/GIF (called when leaving the block through an exception)."""
        if self._gen is not None:
            gen, self._gen = self._gen, None
            try:
                gen.close()
            except Exception:  # the file is discarded anyway
                pass
        if self._ctx is not None:
            ctx, self._ctx = self._ctx, None
            err = VolpackError("aborted")
            try:
                ctx.__exit__(VolpackError, err, None)
            except VolpackError:
                pass

    def __enter__(self) -> MovieWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()
