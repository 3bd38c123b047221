"""Keyword arguments as the text fields the engine parses (proto::parse_mesh_params, parse_structure_options).

The engine, the CLI and the service read every parameter from its text, so a Python value is passed as the text
that reads back to exactly it: an int as its digits, a float as its shortest round-trip repr ("0.1", "1e-05"),
a string as it is. Range checks and their messages are the engine's.
"""

from __future__ import annotations

import numbers
from typing import Any, Dict, Mapping, Sequence

__all__ = ["field_texts"]


def _text(name: str, value: Any) -> str:
    if isinstance(value, str):
        return value
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a number or a string, got {type(value).__name__}")
    if isinstance(value, numbers.Integral):
        return str(int(value))
    return repr(float(value))


def field_texts(values: Mapping[str, Any], accepted: Sequence[str]) -> Dict[str, str]:
    """The given (not None) values as texts by field name; TypeError for a name not in `accepted`."""
    unknown = sorted(set(values) - set(accepted))
    if unknown:
        raise TypeError(f"unknown parameter {unknown[0]!r} (accepted: {', '.join(accepted)})")
    return {name: _text(name, value) for name, value in values.items() if value is not None}
