"""The design sections of the accessory parts (adapter, cover, winding jig), with per-call overrides.

The robot flange presets are in whisker.design.flanges.

Units: mm.
"""

from __future__ import annotations

from pydantic import ValidationError

from whisker.design import Design, DesignError, one_line_errors


def section(d: Design, name: str, **overrides):
    """The design's [name] section with keyword overrides, validated."""
    own = getattr(d, name)
    if not overrides:
        return own
    try:
        return type(own).model_validate({**own.model_dump(), **overrides})
    except ValidationError as err:
        raise DesignError(f"[{name}] " + one_line_errors(err)) from None
