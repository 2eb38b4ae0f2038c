"""Coil safety: refuse levels above the coil's or the driver's rating, and follow each coil's
estimated temperature so that it is limited, then cut, before it reaches its thermal limit.

Levels are signed PWM duties in [-1, 1] (+ = retraction, tip toward the centre), the actuation
backend protocol's unit (see :mod:`whisker.drive.actuation`). A duty ``d`` puts, on average, ``|d| x V_fs``
on the coil, where ``V_fs`` is the voltage at the coil at 100 % duty (:func:`full_scale_voltage`:
``drive.full_scale_voltage`` if measured, else the driver model of ``whisker.coil.driver``).

Heating. The PWM period (1 ms at the default 1 kHz) is far shorter than the coil's electrical time
constant's effect on heating and its thermal time constant (seconds), so the coil sees a square
current of peak ``I = V_fs / R(T)`` at duty ``|d|``: mean power ``|d| I^2 R``, the same as a steady
current ``I_rms = sqrt(|d|) I``. The guard feeds ``I_rms`` to the coil's lumped thermal model
(``whisker.coil.thermal.CoilThermal``, issue 4), whose ``.step(T, I, dt)`` also makes R rise with T.

Limits (all in degrees C, from the design's [drive] section):

* ``cut_C = limit_C - guard_margin`` where ``limit_C`` is the model's first limit (the lowest of
  PLA softening, the magnet's maximum temperature and the enamel class);
* policy ``"derate"`` (default): the allowed |level| falls linearly from the request at
  ``cut_C - guard_derate_band`` to 0 at ``cut_C``, so a held coil settles inside the band instead
  of being dropped; policy ``"cut"``: full level until ``cut_C``;
* at ``cut_C`` the coil is tripped (level 0) and stays off until it has cooled below
  ``cut_C - guard_hysteresis``. The trip looks one guard period ahead with the model (a coil that
  would cross the cut-off before the next update is cut now); the margin below the limit covers
  a late update (at the paper's ~14 K/s, 5 C is ~0.35 s of full drive).

Series resistor (``driver.series_resistance``, default "auto": the smallest E24 value that keeps a
cold coil within ``drive.max_coil_voltage`` at 100 % duty, ``whisker.coil.driver.series_resistance_ohm``).
It lowers the full scale (5.24 -> 3.22 V for the default 7.5 V, L298N, 7 ohm), so level 1 is within
the rating and even a stuck-high output cannot over-volt the coil; a given mean voltage then needs a
higher duty, so the RMS heating penalty 1/|d| shrinks (3 V: 1.07x instead of 1.75x a steady 3 V).
The guard's peak current at temperature T is :func:`coil_current_A`: the coil warms behind the
resistor, so its current falls less than V/R(T). With R_s = 0 everything is as without the resistor.

The estimate is only as good as its start: the guard assumes the coils start at ambient unless
told otherwise (``initial_C``) or given a state file, where the last run's temperatures are stored
and cooled with the same thermal model for the time elapsed since (:meth:`ThermalGuard.save_state`).
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from whisker.files import atomic_write_json


class RatingError(ValueError):
    """A requested level above the coil's or the driver's rating (one-line message)."""


# ---------------------------------------------------------------------------------------------
# ratings
# ---------------------------------------------------------------------------------------------

def full_scale_voltage(design) -> float:
    """Volts at the coil at 100 % duty, V.

    ``drive.full_scale_voltage`` when > 0 (measured across a coil); when 0, the driver model
    (``whisker.coil.driver``): the steady current from ``driver.supply_voltage`` through the bridge's
    drop, the series resistor R_s (``whisker.coil.driver.series_resistance_ohm``, 0 = none) and the
    coil's 20 C resistance, times that resistance: (bridge output) x R_c/(R_c + R_s).
    """
    if design.drive.full_scale_voltage > 0:
        return float(design.drive.full_scale_voltage)
    from whisker.coil import board, driver

    if board.is_hat(design):  # the HAT regulates current: level 1 = the rated current, as cold-coil volts
        try:
            board.check(design)
        except board.BoardError as err:
            raise RatingError(str(err)) from None
        return board.full_scale_current_A(design) * float(design.coil.resistance)
    br = driver.bridge(design.driver.type)
    r = float(design.coil.resistance)
    rs = driver.series_resistance_ohm(design)
    v = driver.coil_current_A(br, float(design.driver.supply_voltage), r, rs) * r
    if not (v > 0 and math.isfinite(v)):
        raise RatingError(f"driver.supply_voltage={design.driver.supply_voltage:g} V is below the "
                          f"{br.name}'s drop: no voltage reaches the coil")
    return float(v)


def driver_current_rating_A(design) -> float:
    """The H-bridge's DC current rating per channel, A (``whisker.coil.driver``; L298N: 2 A)."""
    from whisker.coil import driver

    return float(driver.design_bridge(design).max_current_A)


def max_level(design) -> float:
    """Largest |level| the ratings allow: min(1, max_coil_voltage / full_scale_voltage)."""
    return min(1.0, float(design.drive.max_coil_voltage) / full_scale_voltage(design))


def peak_current_A(design, current_fn: Optional[Callable] = None) -> float:
    """Current in a cold (20 C) coil at 100 % duty: the driver's worst case, A.

    Uses ``whisker.coil.current_A(design, volts_at_coil, temperature_C)`` (issue 4) unless
    ``current_fn`` is given (same signature).
    """
    current_fn = current_fn or _coil_current_fn()
    return float(current_fn(design, full_scale_voltage(design), 20.0))


def check_driver(design, current_fn: Optional[Callable] = None) -> float:
    """Refuse a design whose coil would draw more than the driver channel's rating at 100 % duty.

    Returns the peak current (A). Raises :class:`RatingError`.
    """
    peak = peak_current_A(design, current_fn)
    rating = driver_current_rating_A(design)
    if not math.isfinite(peak) or peak > rating:
        raise RatingError(
            f"a cold coil at {full_scale_voltage(design):.3g} V (100 % duty) draws {peak:.3g} A, above "
            f"the {design.driver.type}'s {rating:g} A per channel (whisker.coil.driver)")
    return peak


def check_levels(design, levels) -> np.ndarray:
    """Validate a level vector: shape (N,), finite, within [-1, 1] and within the rating.

    Returns it as a float array. Raises :class:`RatingError` (rating) or ``ValueError`` (shape,
    NaN/inf, outside [-1, 1]); the message names the whisker.
    """
    n = design.whiskers.count
    arr = np.asarray(levels, dtype=float)
    if arr.shape != (n,):
        raise ValueError(f"levels must have shape ({n},) (one per whisker), got {arr.shape}")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise ValueError(f"level of whisker {int(bad[0])} is {arr[bad[0]]}, not a finite number")
    out = np.flatnonzero(np.abs(arr) > 1.0)
    if out.size:
        raise ValueError(f"level of whisker {int(out[0])} is {arr[out[0]]:g}, outside [-1, 1]")
    top = max_level(design)
    over = np.flatnonzero(np.abs(arr) > top + 1e-12)
    if over.size:
        i = int(over[0])
        raise RatingError(
            f"level {arr[i]:g} on whisker {i} means {abs(arr[i]) * full_scale_voltage(design):.3g} V "
            f"at the coil, above the coil rating drive.max_coil_voltage="
            f"{design.drive.max_coil_voltage:g} V (largest level {top:.3g})")
    safe = design.drive.safe_levels
    if safe:
        if len(safe) != n:
            raise RatingError(f"drive.safe_levels has {len(safe)} entries for {n} whiskers: re-run "
                              "`whisker calibrate stiffness` for this sensor")
        over = np.flatnonzero(np.abs(arr) > np.asarray(safe) + 1e-12)
        if over.size:
            i = int(over[0])
            raise RatingError(f"level {arr[i]:g} on whisker {i} is above its measured safe level {safe[i]:.3g} "
                              "(drive.safe_levels, from `whisker calibrate stiffness`)")
    return arr


def volts_to_levels(design, volts) -> np.ndarray:
    """Signed volts at the coil -> signed duty levels (volts / full_scale_voltage).

    Refuses (RatingError) a magnitude above ``drive.max_coil_voltage`` before any conversion.
    """
    v = np.asarray(volts, dtype=float)
    bad = np.flatnonzero(~np.isfinite(np.atleast_1d(v)))
    if bad.size:
        raise ValueError(f"voltage of whisker {int(bad[0])} is not a finite number")
    vmax = float(design.drive.max_coil_voltage)
    over = np.flatnonzero(np.abs(np.atleast_1d(v)) > vmax + 1e-12)
    if over.size:
        i = int(over[0])
        raise RatingError(f"{np.atleast_1d(v)[i]:g} V on whisker {i} is above the coil rating "
                          f"drive.max_coil_voltage={vmax:g} V")
    vfs = full_scale_voltage(design)
    if np.any(np.abs(v) > vfs + 1e-12):
        raise RatingError(f"{float(np.max(np.abs(v))):g} V is more than the driver delivers at 100 % "
                          f"duty ({vfs:.3g} V at the coil)")
    return np.clip(v / vfs, -1.0, 1.0)


def coil_current_A(design, volts_at_cold_coil, temperature_C=20.0):
    """Coil current at temperature when the drive puts ``volts_at_cold_coil`` across the coil at 20 C, A.

    Without a series resistor (R_s = 0) the coil sees a fixed voltage, as it always has here:
    ``whisker.coil.current_A``, V / R_c(T). With one, the coil hangs on a source of fixed voltage
    behind R_src = R_s + r (r: the bridge's slope, ``whisker.coil.driver``), so a warm coil loses less
    current: I = V (R_c + R_src) / (R_c (R_c(T) + R_src)), R_c = coil.resistance at 20 C. For the
    driver model's full scale this is exactly ``whisker.coil.driver.coil_current_A`` at R_c(T).
    Vectorised over volts and temperature.
    """
    from whisker import coil
    from whisker.coil import board, driver

    if board.is_hat(design):  # regulated: the current follows the level, not the coil's temperature
        v = np.asarray(volts_at_cold_coil, dtype=float)
        if not np.all(np.isfinite(v)):
            raise ValueError(f"volts_at_cold_coil must be finite (got {volts_at_cold_coil!r})")
        out = v / float(design.coil.resistance) + 0.0 * np.asarray(temperature_C, dtype=float)
        return out if np.ndim(out) else float(out)
    rs = driver.series_resistance_ohm(design)
    if rs == 0.0:
        return coil.current_A(design, volts_at_cold_coil, temperature_C)
    v = np.asarray(volts_at_cold_coil, dtype=float)
    if not np.all(np.isfinite(v)):
        raise ValueError(f"volts_at_cold_coil must be finite (got {volts_at_cold_coil!r})")
    r_src = rs + driver.design_bridge(design).r_typ
    r20 = float(design.coil.resistance)
    out = v * (r20 + r_src) / (r20 * (coil.resistance_ohm(design, temperature_C) + r_src))
    return out if np.ndim(out) else float(out)


def _coil_current_fn():
    return coil_current_A


def _fast_current_fn(design):
    """:func:`coil_current_A` with the design's constants worked out once (the guard calls it twice per
    update on a Pi): the same formula, checked against it at two temperatures."""
    from whisker import coil
    from whisker.coil import driver

    rs = driver.series_resistance_ohm(design)
    r20 = float(design.coil.resistance)
    rc20 = float(coil.resistance_ohm(design, 20.0))
    alpha = coil.ALPHA20_PER_K
    r_src = rs + driver.bridge(design.driver.type).r_typ if rs != 0.0 else 0.0

    def fast(_design, volts, temperature_C):
        rt = rc20 * (1.0 + alpha * (np.asarray(temperature_C, dtype=float) - 20.0))
        if rs == 0.0:
            return np.asarray(volts, dtype=float) / rt
        return np.asarray(volts, dtype=float) * (r20 + r_src) / (r20 * (rt + r_src))

    for t in (20.0, 80.0):
        ref, got = float(np.asarray(coil_current_A(design, 1.0, t))), float(fast(design, 1.0, t))
        if not math.isclose(ref, got, rel_tol=1e-9):  # the formula moved on: use the general one
            return coil_current_A
    return fast


def _thermal_model(design):
    """The sensor's thermal network (whisker.coil.thermal_network.ThermalNetwork): every material's own limit."""
    from whisker.coil.thermal_network import ThermalNetwork
    return ThermalNetwork(design)


class _ScalarModel:
    """A one-temperature-per-coil model (``ambient_C``, ``limit_C``, ``step(T, I, dt)``: the lumped
    whisker.coil.thermal.CoilThermal or a test double) seen through the network's interface."""

    def __init__(self, model, n: int):
        self.model, self.n, self.size = model, n, n
        self.ambient_C = float(model.ambient_C)
        self.limit_C = float(model.limit_C)
        self.limit_label = f"coil limit ({self.limit_C:g} C)"
        self._vectorised: Optional[bool] = None

    def initial_state(self, temperature_C=None):
        return np.full(self.n, self.ambient_C if temperature_C is None else float(temperature_C))

    def step_state(self, state, currents, dt):
        state = np.asarray(state, dtype=float)
        i = np.asarray(currents, dtype=float)
        if self._vectorised is None:  # probe once: does the model take numpy arrays?
            try:
                out = np.asarray(self.model.step(state, i, dt), dtype=float)
                ref = np.array([float(self.model.step(float(t), float(c), dt)) for t, c in zip(state, i)])
                self._vectorised = out.shape == state.shape and np.allclose(out, ref, equal_nan=True)
            except Exception:  # noqa: BLE001 - scalar-only model
                self._vectorised = False
        if self._vectorised:
            return np.asarray(self.model.step(state, i, dt), dtype=float)
        return np.array([float(self.model.step(float(t), float(c), dt)) for t, c in zip(state, i)])

    def winding_C(self, state):
        return np.asarray(state, dtype=float)

    def headroom(self, state):
        return self.limit_C - np.asarray(state, dtype=float), [self.limit_label] * self.n


# ---------------------------------------------------------------------------------------------
# the guard
# ---------------------------------------------------------------------------------------------

class ThermalGuard:
    """Follows each coil's temperature from the levels applied and limits what may be applied next.

    Use: ``allowed = guard.allow(requested, now)`` each time levels are applied and periodically
    while any coil is on (the actuator's watchdog thread does this every ``drive.guard_period``).
    ``allow`` first integrates the temperatures from the previous call to ``now`` with the levels
    that were actually applied in between, then returns the levels permitted from now on.

    thermal: an object with ``ambient_C``, ``limit_C`` and ``step(T, I, dt) -> T`` (default
    ``whisker.coil.thermal.CoilThermal(design)``); current_fn(design, volts, temperature_C) -> A (default
    ``whisker.coil.current_A``). Both are injectable for tests and for other coil models.
    """

    POLICIES = ("derate", "cut")

    def __init__(self, design, *, thermal=None, current_fn: Optional[Callable] = None,
                 policy: str = "derate", clock: Callable[[], float] = time.monotonic,
                 initial_C: Optional[float] = None, state_file: Optional[Path] = None,
                 max_substep_s: float = 0.05):
        if policy not in self.POLICIES:
            raise ValueError(f"guard policy must be one of {self.POLICIES}, got {policy!r}")
        self.design = design
        self.n = design.whiskers.count
        self.thermal = thermal if thermal is not None else _thermal_model(design)
        self.model = self.thermal if hasattr(self.thermal, "step_state") else _ScalarModel(self.thermal, self.n)
        self.current_fn = current_fn or _fast_current_fn(design)
        self.policy = policy
        self.clock = clock
        self.max_substep_s = float(max_substep_s)
        d = design.drive
        self.limit_C = float(self.model.limit_C)          # the first (weakest) material's limit
        self.limit_label = str(getattr(self.model, "limit_label", f"{self.limit_C:g} C"))
        self.ambient_C = float(self.model.ambient_C)
        self.margin_K = float(d.guard_margin)
        self.band_K = float(d.guard_derate_band)
        self.hysteresis_K = float(d.guard_hysteresis)
        # in the first limit's terms (every material is held the same margins below its own limit)
        self.cut_C = self.limit_C - self.margin_K
        self.derate_from_C = self.cut_C - self.band_K
        self.resume_C = self.cut_C - self.hysteresis_K
        if self.cut_C <= self.ambient_C:
            raise ValueError(f"guard cut-off {self.cut_C:g} C ({self.limit_label} - "
                             f"drive.guard_margin) is not above ambient {self.ambient_C:g} C")
        self.v_fs = full_scale_voltage(design)
        start = self.ambient_C if initial_C is None else float(initial_C)
        if not math.isfinite(start):
            raise ValueError(f"initial coil temperature must be finite, got {initial_C}")
        self.node_state = self.model.initial_state(start)
        self.state_file = Path(state_file) if state_file else None
        if self.state_file is not None and initial_C is None:
            self._load_state()
        self._sync()
        self.tripped = self.headroom_K <= self.margin_K
        self.applied = np.zeros(self.n)
        self.peak_C = self.temperatures.copy()
        self.trips = np.zeros(self.n, dtype=int)
        self.trip_reason = [""] * self.n
        self._t = self.clock()

    # -- physics ---------------------------------------------------------------------------
    def _sync(self) -> None:
        """Winding temperatures and each coil's headroom (K below its weakest material) from the state."""
        self.temperatures = np.asarray(self.model.winding_C(self.node_state), dtype=float).copy()
        self.headroom_K, self.limited_by = self.model.headroom(self.node_state)
        self.headroom_K = np.asarray(self.headroom_K, dtype=float)

    def _rms_currents(self, temps: np.ndarray, levels: np.ndarray) -> np.ndarray:
        try:
            peak = np.broadcast_to(np.asarray(self.current_fn(self.design, self.v_fs, temps), dtype=float),
                                   temps.shape)
        except Exception:  # noqa: BLE001 - a scalar-only current model
            peak = np.array([float(self.current_fn(self.design, self.v_fs, float(t))) for t in temps])
        return np.where(levels != 0.0, np.sqrt(np.abs(levels)) * peak, 0.0)

    def _step_state(self, state: np.ndarray, levels: np.ndarray, h: float) -> np.ndarray:
        """One thermal step of every coil at `levels` (PWM RMS currents at the windings' temperatures)."""
        temps = np.asarray(self.model.winding_C(state), dtype=float)
        return np.asarray(self.model.step_state(state, self._rms_currents(temps, levels), h), dtype=float)

    def advance(self, now: Optional[float] = None) -> np.ndarray:
        """Integrate every coil's temperature up to `now` with the levels applied since the last call."""
        now = self.clock() if now is None else float(now)
        dt = now - self._t
        if dt < 0 or not math.isfinite(dt):
            raise ValueError(f"guard clock went backwards or is not finite (dt={dt})")
        if dt > 0:
            # sub-steps re-evaluate the current as R(T) rises (constant-voltage PWM); while every
            # coil is off the model cools them in one call (it is stable for any dt)
            steps = 1 if not np.any(self.applied) else min(200, max(1, math.ceil(dt / self.max_substep_s)))
            h = dt / steps
            x = self.node_state
            for _ in range(steps):
                x = self._step_state(x, self.applied, h)
            temps = np.asarray(self.model.winding_C(x), dtype=float)
            bad = np.flatnonzero(~np.isfinite(temps))
            if bad.size or not np.all(np.isfinite(x)):
                i = int(bad[0]) if bad.size else 0
                raise FloatingPointError(f"coil {i} temperature estimate became {temps[i]}")
            self.node_state = x
            self._sync()
            self.peak_C = np.maximum(self.peak_C, self.temperatures)
        self._t = now
        return self.temperatures

    # -- policy ----------------------------------------------------------------------------
    def predict(self, levels, horizon_s: float) -> np.ndarray:
        """Each coil's winding temperature `horizon_s` from now if `levels` were held (no update)."""
        return np.asarray(self.model.winding_C(self._predict_state(levels, horizon_s)), dtype=float)

    def _predict_state(self, levels, horizon_s: float) -> np.ndarray:
        if horizon_s <= 0:
            return self.node_state.copy()
        return self._step_state(self.node_state, np.asarray(levels, dtype=float), horizon_s)

    def factor(self, requested=None) -> np.ndarray:
        """Fraction (0..1) of the requested |level| each coil may have from now on.

        Every material that reaches one of a coil's nodes (or a shared node) is held below its own
        limit; the one with the least headroom sets the coil's factor (the weakest sets the limit):
        derating over ``guard_derate_band`` down to 0 at ``guard_margin`` below that material's limit,
        where the coil trips. A coil trips when its headroom, or the headroom the model predicts one
        guard period ahead at the level it would apply (the request times the derate factor), reaches
        the margin: so the cut comes before the crossing, not one update after it.
        """
        room = self.headroom_K
        f = np.ones(self.n)
        if self.policy == "derate" and self.band_K > 0:
            f = np.clip((room - self.margin_K) / self.band_K, 0.0, 1.0)
        ahead_room, ahead_by = room, self.limited_by
        if requested is not None:
            x = self._predict_state(np.asarray(requested, dtype=float) * f, float(self.design.drive.guard_period))
            r2, by2 = self.model.headroom(x)
            r2 = np.asarray(r2, dtype=float)
            ahead_by = [b2 if v2 < v1 else b1 for v1, v2, b1, b2 in zip(room, r2, self.limited_by, by2)]
            ahead_room = np.minimum(room, r2)
        hit = ahead_room <= self.margin_K
        newly = (~self.tripped) & hit
        for i in np.flatnonzero(newly):
            self.trip_reason[int(i)] = ahead_by[int(i)]
        self.trips += newly
        self.tripped = np.where(self.tripped, room <= self.margin_K + self.hysteresis_K, hit)
        return np.where(self.tripped, 0.0, f)

    def allow(self, requested, now: Optional[float] = None) -> np.ndarray:
        """Advance to `now`, then return the levels allowed from now on (and remember them)."""
        req = np.asarray(requested, dtype=float)
        if req.shape != (self.n,) or not np.all(np.isfinite(req)):
            raise ValueError(f"guard: levels must be {self.n} finite numbers, got {req!r}")
        self.advance(now)
        allowed = req * self.factor(req)
        self.applied = allowed.copy()
        return allowed

    def state(self) -> dict:
        """Temperatures, trip flags and thresholds, for logs and recordings."""
        return {"temperatures_C": [round(float(x), 3) for x in self.temperatures],
                "tripped": [bool(x) for x in self.tripped],
                "trips": [int(x) for x in self.trips],
                "peak_C": [round(float(x), 3) for x in self.peak_C],
                "headroom_K": [round(float(x), 3) for x in self.headroom_K],
                "limited_by": list(self.limited_by), "trip_reason": list(self.trip_reason),
                "cut_C": self.cut_C, "limit_C": self.limit_C, "first_limit": self.limit_label,
                "policy": self.policy}

    # -- persistence -----------------------------------------------------------------------
    def save_state(self) -> None:
        """Store the temperatures and the wall-clock time, so the next run starts from them."""
        if self.state_file is None:
            return
        self.advance()
        atomic_write_json(self.state_file, {"wall_time_s": time.time(), "digest": self.design.digest(),
                                            "temperatures_C": [float(x) for x in self.temperatures],
                                            "nodes_C": [float(x) for x in self.node_state]})

    def _load_state(self) -> None:
        try:
            data = json.loads(self.state_file.read_text())
            nodes = np.asarray(data.get("nodes_C", data["temperatures_C"]), dtype=float)
            elapsed = max(0.0, time.time() - float(data["wall_time_s"]))
        except FileNotFoundError:
            return
        except (ValueError, KeyError, TypeError) as err:
            raise ValueError(f"unreadable coil state file {self.state_file}: {err}") from None
        if nodes.shape != np.shape(self.node_state) or not np.all(np.isfinite(nodes)):
            return  # another design's (or model's) state: start from ambient
        if elapsed > 3600.0:
            return  # an hour off: every coil is back at ambient
        # cool every node with the same thermal model for the time since the last run (no current);
        # the model is implicit, so a few steps are stable and accurate enough
        x = nodes
        steps = min(100, max(1, math.ceil(elapsed / 1.0)))
        for _ in range(steps):
            x = np.asarray(self.model.step_state(x, np.zeros(self.n), elapsed / steps), dtype=float)
        if np.all(np.isfinite(x)):
            self.node_state = np.maximum(x, self.ambient_C)
