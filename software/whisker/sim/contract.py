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
    """Radial coil force per ampere at `gap_mm` (N/A), vectorised (whisker.coil.magnetics)."""
    m = _mod("whisker.coil.magnetics", "the magnetics effect")
    return np.asarray(m.force_per_ampere_N(design, np.asarray(gap_mm, dtype=float), model=model), dtype=float)


def current_A(design, volts, temperature_C=20.0) -> np.ndarray:
    """Coil current (A) when the drive puts `volts` across the coil at 20 C, at `temperature_C`:
    ``whisker.drive.guard.coil_current_A``, the actuation module's one definition (V / R(T) without a
    series resistor; behind ``driver.series_resistance`` a warm coil loses less current)."""
    m = _mod("whisker.drive.guard", "the magnetics effect")
    return np.asarray(m.coil_current_A(design, volts, temperature_C), dtype=float)


def pwm_rms_current_A(mean_current_A, levels) -> np.ndarray:
    """The current that heats a PWM-driven coil, A: RMS = sqrt(|d|) x peak = |mean| / sqrt(|d|) at duty
    d = level (the coil's L/R is far shorter than the PWM period). Force follows the mean current, heat
    the RMS one, as in whisker.drive.guard (module doc); 0 where the level is 0."""
    i = np.abs(np.asarray(mean_current_A, dtype=float))
    d = np.abs(np.asarray(levels, dtype=float))
    return np.where(d > 0, i / np.sqrt(np.where(d > 0, d, 1.0)), 0.0)


def copper_mass_g(design) -> float:
    """Copper mass of one coil (g), from the winding (whisker.coil)."""
    m = _mod("whisker.coil", "the whisker inertia")
    return float(m.winding(design).copper_mass_g)


def full_scale_voltage(design) -> float:
    """Volts at the coil at level 1 (100 % duty), V: ``whisker.drive.guard.full_scale_voltage`` (the actuation
    module's one definition: ``drive.full_scale_voltage`` if measured, else the driver model)."""
    m = _mod("whisker.drive.guard", "the meaning of an actuation level")
    return float(m.full_scale_voltage(design))


def volts_to_level(design, volts: float) -> float:
    """Signed volts at the coil -> signed level (``whisker.drive.guard.volts_to_levels``: refused above the
    coil rating or beyond full scale)."""
    m = _mod("whisker.drive.guard", "the meaning of an actuation level")
    return float(m.volts_to_levels(design, float(volts)))


def coil_thermal(design):
    """The sensor's thermal network (whisker.coil.thermal_network.ThermalNetwork, the guard's model):
    .ambient_C, .initial_state(), .step_state(state, I_rms (n,), dt), .winding_C(state)."""
    m = _mod("whisker.coil.thermal_network", "the heating effect")
    return m.ThermalNetwork(design)


def marker_pixels(design, xyz_mm, mtx=None, dist=None, model: str = "standard") -> np.ndarray:
    """Pixel centres of markers at sensor-frame xyz (mm): pinhole, optional lens distortion of `model`
    (whisker.vision.lens: standard, rational or fisheye)."""
    m = _mod("whisker.vision.render", "the camera effect")
    kw = {} if mtx is None else {"mtx": mtx, "dist": dist, "model": model}
    return np.asarray(m.marker_pixels(design, np.asarray(xyz_mm, dtype=float), **kw), dtype=float)


def load_calibration(path):
    """(mtx, dist, model) from an .npz lens calibration of any model (whisker.vision.lens.load_lens)."""
    m = _mod("whisker.vision.lens", "the camera's lens distortion")
    lens = m.load_lens(path)
    return lens.mtx, lens.dist, lens.model


def render_frame(design, markers_px, **kw) -> np.ndarray:
    m = _mod("whisker.vision.render", "the camera effect")
    return m.render_frame(design, markers_px, **kw)


def tracker(design, method: str = "roi", calibration=None):
    m = _mod("whisker.vision.tracking", "the tracking effect")
    return m.Tracker(design, method=method, calibration=calibration)


def design_sense(design) -> int:
    """+1/-1: the sense of the whisker numbering in the camera image (whisker.vision.render)."""
    m = _mod("whisker.vision.render", "the dataset's dataset.json")
    return int(m.design_sense(design))


def geometry_deflection(design, dx_px, dy_px):
    m = _mod("whisker.vision.geometry", "the tip estimate")
    return m.deflection(design, dx_px, dy_px)
