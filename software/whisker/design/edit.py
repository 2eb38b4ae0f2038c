"""Text edits of a design TOML that keep everything else (comments, order, other sections) as it was.

The calibration commands write their results as a copy of the design file with a few keys set, so a
person can diff it against the original and use it with ``--design FILE``.
"""

from __future__ import annotations

import re


def set_keys(toml_text: str, section: str, values: dict, comment: str = "") -> str:
    """`toml_text` with `section`.key = value for every item of `values` (TOML literals as text).

    An existing key's line is replaced in place; a new key goes after the section's last key; a
    missing section is appended at the end.
    """
    lines = toml_text.splitlines()
    tail = f"  # {comment}" if comment else ""
    head = next((i for i, ln in enumerate(lines) if re.match(rf"\s*\[{re.escape(section)}\]\s*(#.*)?$", ln)), None)
    if head is None:
        lines += ["", f"[{section}]"] + [f"{k} = {v}{tail}" for k, v in values.items()]
        return "\n".join(lines) + "\n"
    end = next((i for i in range(head + 1, len(lines)) if re.match(r"\s*\[", lines[i])), len(lines))
    body = lines[head + 1:end]
    todo = dict(values)
    for k in list(todo):
        pat = re.compile(rf"\s*{re.escape(k)}\s*=")
        for j, ln in enumerate(body):
            if pat.match(ln):
                body[j] = f"{k} = {todo.pop(k)}{tail}"
                # a replaced value's continuation comment lines (indented '#') described the old value
                while j + 1 < len(body) and re.match(r"\s{8,}#", body[j + 1]):
                    del body[j + 1]
                break
    last = max((j for j, ln in enumerate(body) if ln.strip() and not ln.lstrip().startswith("#")), default=-1)
    body[last + 1:last + 1] = [f"{k} = {v}{tail}" for k, v in todo.items()]
    return "\n".join(lines[:head + 1] + body + lines[end:]) + "\n"
