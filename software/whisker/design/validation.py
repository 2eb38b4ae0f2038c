"""The design model's errors, at the bottom of the design package: every module that validates a part
of the design (sections, tables, sizing rules) raises these, and the model imports them from here.
"""

from __future__ import annotations

from pydantic import ValidationError


class DesignError(ValueError):
    """A design that cannot be built. The message is one line naming the parameter(s)."""


def one_line_errors(err: ValidationError) -> str:
    """A pydantic ValidationError as one line: ``key.path: message (got value); ...``.

    The offending input is shown unless it is a whole section (a dict), which would flood the line.
    """
    msgs = []
    for e in err.errors():
        loc = ".".join(str(p) for p in e["loc"])
        msg = e["msg"].removeprefix("Value error, ")
        inp = e.get("input")
        shown = "" if isinstance(inp, dict) else f" (got {inp!r})"
        msgs.append(f"{loc}: {msg}{shown}" if loc else msg)
    return "; ".join(msgs)
