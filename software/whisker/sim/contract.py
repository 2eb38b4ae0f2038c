"""The simulator's only door to the other helpers' modules (see notes/contracts.md).

Each function imports its module when first called, so a scene that does not need an effect never
loads it, and a missing module fails with one line naming the module and the contract, instead of
an ImportError deep in a run.
"""

from __future__ import annotations

import importlib

import numpy as np


class MissingModule(RuntimeError):
    """A contract module the scene needs is not installed."""


def _mod(name: str, what: str):
    try:
        return importlib.import_module(name)
    except ImportError as err:
        raise MissingModule(f"{what} needs {name} ({err}); see notes/contracts.md") from None


def force_per_ampere_N(design, gap_mm, model: str = "table") -> np.ndarray:
    """Radial coil force per ampere at `gap_mm` (N/A), vectorised (whisker.magnetics)."""
    m = _mod("whisker.magnetics", "the magnetics effect")
    return np.asarray(m.force_per_ampere_N(design, np.asarray(gap_mm, dtype=float), model=model), dtype=float)


def current_A(design, volts, temperature_C=20.0) -> np.ndarray:
    """Coil current at `volts` across the coil and `temperature_C` (A), (whisker.coil)."""
    m = _mod("whisker.coil", "the magnetics effect")
    return np.asarray(m.current_A(design, volts, temperature_C), dtype=float)


def copper_mass_g(design) -> float:
    """Copper mass of one coil (g), from the winding (whisker.coil)."""
    m = _mod("whisker.coil", "the whisker inertia")
    return float(m.winding(design).copper_mass_g)


def coil_thermal(design):
    """A lumped coil thermal model with .ambient_C, .limit_C, .step(T, I, dt) (whisker.thermal)."""
    m = _mod("whisker.thermal", "the heating effect")
    return m.CoilThermal(design)


def marker_pixels(design, xyz_mm, mtx=None, dist=None) -> np.ndarray:
    """Pixel centres of markers at sensor-frame xyz (mm): pinhole, optional lens distortion."""
    m = _mod("whisker.render", "the camera effect")
    kw = {} if mtx is None else {"mtx": mtx, "dist": dist}
    return np.asarray(m.marker_pixels(design, np.asarray(xyz_mm, dtype=float), **kw), dtype=float)


def load_calibration(path):
    """(mtx, dist) from an .npz lens calibration (whisker.tracking)."""
    m = _mod("whisker.tracking", "the camera's lens distortion")
    return m.load_calibration(path)


def render_frame(design, markers_px, **kw) -> np.ndarray:
    m = _mod("whisker.render", "the camera effect")
    return m.render_frame(design, markers_px, **kw)


def tracker(design, method: str = "paper", calibration=None):
    m = _mod("whisker.tracking", "the tracking effect")
    return m.Tracker(design, method=method, calibration=calibration)


def geometry_deflection(design, dx_px, dy_px):
    m = _mod("whisker.geometry", "the tip estimate")
    return m.deflection(design, dx_px, dy_px)
