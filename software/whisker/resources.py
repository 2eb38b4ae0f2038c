"""Where the shipped data lives: the hardware folder (default design, printer profile, tables),
the example sequences and the example sim scenes, found through :mod:`importlib.resources`.

One source for each file: in a clone (editable install) ``whisker.hw`` *is* the repository's
``hw/`` folder, so ``hw/sensor.toml`` stays the file people edit; in a wheel the same files are
copied into the package (pyproject.toml maps ``hw/`` -> ``whisker.hw`` and ``docs/sequences/`` ->
``whisker.sequences`` and ships every non-Python file under them).
"""

from __future__ import annotations

import os
from importlib.resources import files
from pathlib import Path


def _folder(package: str) -> Path:
    # Wheels and editable installs put the data in plain folders; a zipped install is not supported
    # (the slicer and CadQuery need real paths).
    return Path(os.fspath(files(package)))


def hw_dir() -> Path:
    """The hardware data folder: ``hw/`` in a clone, ``site-packages/whisker/hw`` from a wheel."""
    return _folder("whisker.hw")


def default_design_path() -> Path:
    """The default design file (the paper's sensor): ``hw/sensor.toml``."""
    return hw_dir() / "sensor.toml"


def sequences_dir() -> Path:
    """The example actuation sequences (``docs/sequences/`` in a clone)."""
    return _folder("whisker.sequences")


def scenes_dir() -> Path:
    """The example sim scenes and the paper's objects (``software/whisker/sim/scenes/``)."""
    return _folder("whisker") / "sim" / "scenes"  # not files("whisker.sim"): that would import the simulator


def example(path: str | os.PathLike, folder: Path) -> Path:
    """``path`` if it names an existing file, else the shipped example of that name (with or
    without ``.toml``) in ``folder``; else ``path`` unchanged so the caller reports it missing."""
    p = Path(path)
    if p.exists() or p.parent != Path("."):
        return p
    for name in (p.name, p.name + ".toml"):
        if (folder / name).is_file():
            return folder / name
    return p
