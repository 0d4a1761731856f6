"""JSON for reports and headers: NaN and infinities become null (JSON has no spelling for
them); metadata becomes JSON types."""

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


def jsonable(meta: dict) -> dict:
    """``meta`` as JSON types (arrays become lists, anything else unknown its ``str``), for
    a header; ``meta`` itself when it already is."""
    import json

    try:
        json.dumps(meta)
        return meta
    except TypeError:
        return json.loads(
            json.dumps(meta, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o))
        )
