"""The design model: one validated, frozen :class:`Design` from hw/sensor.toml, and everything that sizes
or checks it (sections, sizing rules, fastener/flange/camera-board tables, the coil former and wire, leads,
the printer profile).

``whisker.design.load_design`` and the names below are the public door; the modules inside import each
other directly (model, sections, validation, ...), never this package, so it has no import cycle.
"""

from whisker.design.model import (DEFAULT_DESIGN, Design, apply_overrides, default_design, design_from_dict,
                                  load_design, parse_value)
from whisker.design.validation import DesignError, one_line_errors

__all__ = ["DEFAULT_DESIGN", "Design", "DesignError", "apply_overrides", "default_design", "design_from_dict",
           "load_design", "one_line_errors", "parse_value"]
