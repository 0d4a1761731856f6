"""Strict JSON for reports: NaN and infinities become null (JSON has no spelling for them)."""

from __future__ import annotations

from typing import Any


def finite_json(o: Any) -> Any:
    """``o`` with every non-finite float replaced by None, recursively."""
    if isinstance(o, float):
        return o if o == o and abs(o) != float("inf") else None
    if isinstance(o, dict):
        return {k: finite_json(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [finite_json(v) for v in o]
    return o
