"""The settings of an animation: how frames are coded (lossless, to ``max_error`` or to
``quality``), how motion is searched and compensated, and the codecs they imply; read
back from a file's header by the decoder."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from ..errors import FormatError, OptionError
from . import motion

# -- settings ----------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Settings:
    """How frames are coded; stored in the header (``codec`` and ``motion``)."""

    mode: str = "lossless"  # lossless | bounded | coef
    max_error: float | None = None
    quality: int | None = None
    wavelet: str = "53"
    coder: str = "arith"
    order: str = "dfs"
    max_levels: int | None = None
    search: int = motion.DEFAULT_RADIUS
    method: str = "fast"
    precision: str = "quarter"
    compensation: str = "windowed"
    b_residual: bool = True
    rule: str = motion.RULE
    whole_frame: bool = True  # whole-frame shifts tried where the scene moves as one
    i_max_error: float | None = None  # bound of I-frames that anchor others (None: max_error)
    fill_value: float | None = None  # voxels of this value are kept exactly, as NaN and Inf

    def __post_init__(self) -> None:
        if self.fill_value is not None and not (
            isinstance(self.fill_value, (int, float)) and math.isfinite(self.fill_value)
        ):
            raise OptionError(f"expected a finite fill_value, found {self.fill_value!r}")
        if self.mode not in ("lossless", "bounded", "coef"):
            raise OptionError(f"expected mode lossless, bounded or coef, found {self.mode!r}")
        if self.mode == "bounded" and not (
            self.max_error is not None and 0 < self.max_error < 1e300  # 2 * bound stays finite
        ):
            raise OptionError(f"expected a max_error in (0, 1e300), found {self.max_error!r}")
        if self.i_max_error is not None and not (
            self.mode == "bounded" and 0 < self.i_max_error <= self.max_error
        ):
            raise OptionError(
                f"expected i_max_error, an I-frame bound, in (0, max_error = "
                f"{self.max_error}] with max_error=, found {self.i_max_error!r} in "
                f"{self.mode} coding"
            )
        if self.mode == "coef" and not (self.quality and 1 <= int(self.quality) <= 65535):
            raise OptionError(f"expected a quality in 1..65535, found {self.quality!r}")
        if self.method not in motion.SEARCH_METHODS:
            raise OptionError(
                f"expected a motion search method in {motion.SEARCH_METHODS}, found {self.method!r}"
            )
        if self.precision not in motion.PRECISIONS:
            raise OptionError(
                f"expected a vector precision in {motion.PRECISIONS}, found {self.precision!r}"
            )
        if self.compensation not in motion.COMPENSATIONS:
            raise OptionError(
                f"expected compensation in {motion.COMPENSATIONS}, found {self.compensation!r}"
            )
        if self.rule != motion.RULE:
            raise OptionError(f"expected the prediction rule {motion.RULE!r}, found {self.rule!r}")
        if not 0 <= int(self.search) <= 64:
            raise OptionError(f"expected a search range of 0..64 voxels, found {self.search}")
        if not self.b_residual and self.mode != "coef":
            raise OptionError(
                "B-frames without a residual have no error bound: use them with quality= only"
            )

    def codec_config(self) -> dict[str, Any]:
        keys = ("mode", "max_error", "quality", "wavelet", "coder", "order", "max_levels")
        out = {k: getattr(self, k) for k in keys}
        if self.i_max_error is not None:
            out["i_max_error"] = self.i_max_error
        if self.fill_value is not None:
            out["fill_value"] = self.fill_value
        return out

    def anchor_i(self) -> Settings:
        """The settings of an I-frame that anchors predictions (flag bit 7)."""
        return dataclasses.replace(self, max_error=self.i_max_error, i_max_error=None)

    def motion_config(self) -> dict[str, Any]:
        keys = ("search", "method", "precision", "compensation", "b_residual", "rule")
        keys += ("whole_frame",)
        return {k: getattr(self, k) for k in keys}

    @classmethod
    def from_header(cls, hdr: dict) -> Settings:
        if isinstance(hdr.get("motion"), dict) and "rule" not in hdr["motion"]:
            raise FormatError(
                "animation coded with an earlier prediction rule (no motion.rule in its "
                f"header; quarter-voxel samples were box means): this volpack predicts by "
                f"rule {motion.RULE!r} only, so encode the frames again"
            )
        from ..format.header import dataclass_config

        codec = dataclass_config(cls, hdr["codec"], "animation codec settings")
        moves = dataclass_config(cls, hdr["motion"], "animation motion settings")
        try:
            return cls(**codec, **moves)
        except (KeyError, TypeError, ValueError, ArithmeticError) as e:
            raise FormatError(f"bad animation header settings: {e}") from None

    def inner(self) -> dict[str, Any]:
        d = {"wavelet": self.wavelet, "coder": self.coder, "order": self.order}
        if self.max_levels is not None:
            d["max_levels"] = self.max_levels
        return d

    def scale(self, vrange: float) -> float:
        """The size of an error this setting treats as small (motion search penalty)."""
        if self.mode == "bounded":
            return float(self.max_error)
        if self.mode == "coef":
            return max(vrange, 1.0) / (int(self.quality) + 1)
        return 1.0
