"""Does a grasp fit the coils' thermal limits? The paper's protocol (retract, lift 3 cm at the arm's
speed, hold, release) run through the thermal guard and the thermal network, every material's
temperature through it, and the holding level that keeps the guard out of it.

Timeline (:class:`Protocol`): the coils of the configuration at the grasp level while the whiskers
close (``close_s``), then at ``hold_level`` while the arm lifts ``lift_mm`` at ``lift_mm_s`` and holds
``hold_s``, then off (``release_s`` of cooling). The defaults are the paper's lift (Sec. III-B: 3 cm)
at the arm speed and closing time of the simulator's and the closed loop's grasp (whisker.sim.protocol:
T_CLOSE = 0.3 s, 30 mm in T_LIFT = 0.5 s; tests/test_thermal_protocol.py checks they agree), with
the 2 s hold of issue 27.

A grasp *fits* when the guard (whisker.drive.guard.ThermalGuard at its update period, on the
thermal network) never reduces a level: every material stays above its derate band
(``drive.guard_margin + drive.guard_derate_band`` below its own limit). :func:`fit_hold_level` finds
the highest holding level that fits (bisection); the grasp's force at the contact falls with the
level in proportion to the mean coil current.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Protocol:
    close_s: float = 0.3        # s at the grasp level while the whiskers close (whisker.sim.protocol.T_CLOSE)
    lift_mm: float = 30.0       # mm (paper: 3 cm)
    lift_mm_s: float = 60.0     # mm/s, the arm's speed (whisker.sim.protocol: 30 mm in T_LIFT = 0.5 s)
    hold_s: float = 2.0         # s at the top
    release_s: float = 3.0      # s of cooling after release (coils off)

    def __post_init__(self):
        for k in ("close_s", "lift_mm", "lift_mm_s", "hold_s", "release_s"):
            v = getattr(self, k)
            if not (math.isfinite(v) and v >= 0) or (k == "lift_mm_s" and v <= 0):
                raise ValueError(f"grasp protocol: {k} must be a finite number >= 0 (> 0 for the speed), got {v!r}")

    @property
    def lift_s(self) -> float:
        return self.lift_mm / self.lift_mm_s

    def phases(self, level: float, hold_level: float) -> list[tuple[str, float, float]]:
        """(phase, seconds, level) in order."""
        return [("close", self.close_s, level), ("lift", self.lift_s, hold_level), ("hold", self.hold_s, hold_level),
                ("release", self.release_s, 0.0)]


@dataclass
class ProtocolRun:
    times_s: np.ndarray                  # (k,)
    phase: list                          # (k,) phase names
    requested: np.ndarray                # (k,) requested level on the active coils
    allowed: np.ndarray                  # (k,) the guard's level on the first active coil
    materials_C: dict                    # "part (material)" -> (k,) hottest temperature, C
    limits_C: dict                       # "part (material)" -> limit, C
    first_reduced_s: float | None        # when the guard first reduced a level (None: never)
    trips: int
    trip_reason: str

    @property
    def fits(self) -> bool:
        return self.first_reduced_s is None and self.trips == 0

    def peaks(self) -> dict[str, float]:
        return {k: float(np.max(v)) for k, v in self.materials_C.items()}


def run_protocol(design, level: float, hold_level: float | None = None, protocol: Protocol = Protocol(),
                 active=None, policy: str = "derate", thermal=None) -> ProtocolRun:
    """The protocol on the coils `active` (mask, default all) through the guard on the thermal network."""
    from whisker.coil.thermal_network import ThermalNetwork
    from whisker.drive.guard import ThermalGuard

    n = design.whiskers.count
    mask = np.ones(n, bool) if active is None else np.asarray(active, dtype=bool)
    hold_level = level if hold_level is None else hold_level
    net = thermal if thermal is not None else ThermalNetwork(design)
    clock = [0.0]
    g = ThermalGuard(design, thermal=net, policy=policy, clock=lambda: clock[0])
    dt = float(design.drive.guard_period)
    first = int(np.flatnonzero(mask)[0])
    ts, ph, req, alw = [0.0], ["start"], [0.0], [0.0]
    mats = {k: [v] for k, v in net.material_temperatures(g.node_state).items()}
    reduced = None
    for name, seconds, lv in protocol.phases(level, hold_level):
        for _ in range(int(round(seconds / dt))):
            clock[0] += dt
            want = np.where(mask, lv, 0.0)
            a = g.allow(want, clock[0])
            if reduced is None and np.any(np.abs(a) < np.abs(want) - 1e-12):
                reduced = clock[0]
            ts.append(clock[0])
            ph.append(name)
            req.append(lv)
            alw.append(float(a[first]))
            for k, v in net.material_temperatures(g.node_state).items():
                mats[k].append(v)
    limits = {f"{k}": lim for k, lim in _limits(net).items()}
    reason = next((r for r in g.trip_reason if r), "")
    return ProtocolRun(np.array(ts), ph, np.array(req), np.array(alw), {k: np.array(v) for k, v in mats.items()},
                       limits, reduced, int(g.trips.sum()), reason)


def _limits(net) -> dict[str, float]:
    from whisker.coil import thermal_materials as tm
    out: dict[str, float] = {}
    for _node, role, name, lim in net.limit_table:
        out[f"{tm.ROLES[role][0]} ({name})"] = lim
    return out


def fit_hold_level(design, level: float, protocol: Protocol = Protocol(), active=None, resolution: float = 1e-3) -> float:
    """Highest holding level (0..level) with which the protocol fits (the guard never steps in);
    0 when even the closing at `level` alone does not fit."""
    from whisker.coil.thermal_network import ThermalNetwork

    net = ThermalNetwork(design)
    if run_protocol(design, level, level, protocol, active, thermal=net).fits:
        return float(level)
    if not run_protocol(design, level, 0.0, protocol, active, thermal=net).fits:
        return 0.0
    lo, hi = 0.0, float(level)
    while hi - lo > resolution:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if run_protocol(design, level, mid, protocol, active, thermal=net).fits else (lo, mid)
    return lo
