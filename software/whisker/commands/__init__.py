"""One module per `whisker` subcommand, named for it, each exposing `cli` (a click command or group);
grouped by what the commands do: build/ makes the hardware from the design, sensor/ runs the sensor.
`whisker.cli` finds them by walking these folders (:func:`command_modules`).

Keep heavy imports inside the command functions so that `whisker --help` stays fast.
"""

from __future__ import annotations

import pkgutil


def command_modules() -> dict[str, str]:
    """Subcommand name -> the dotted module that holds it (every public module under this package)."""
    out = {}
    for m in pkgutil.walk_packages(__path__, __name__ + "."):
        leaf = m.name.rsplit(".", 1)[1]
        if not m.ispkg and not leaf.startswith("_"):
            out[leaf] = m.name
    return out
