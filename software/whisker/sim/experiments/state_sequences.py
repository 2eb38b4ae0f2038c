"""Labelled state sequences from the simulator: rest, contact with an object, airflow, own actuation.

The whiskers are the simulator's spring-damper bodies (`whisker.coil.kinematics`, own implicit
integrator) driven by, segment by segment:

- ``rest``: nothing; truth rest.
- ``contact``: an object pushes the tips of some whiskers in a random direction (a one-sided stiff
  wall, 50x the membrane stiffness, moving in over `ramp_s`, holding, moving out); truth contact
  on those whiskers while the wall touches them (its torque > 0), rest on the others.
- ``airflow``: `whisker.sim.effects.airflow.AirflowDrag` on every rod; truth dynamic while the flow is on.
- ``actuation``: some coils driven at a level (`whisker.coil.kinematics.magnetic_torque` with the
  coil current of the level); truth rest: the whisker moves, but nothing touched it. The expected
  displacement of that level (static equilibrium) is returned, as a controller knows its command.

A camera at `fps` samples the marker displacement in pixels (design.mm_per_px) with per-whisker
Gaussian tracking noise (`noise_px` x a factor 0.5..1.5 per whisker). A contact whose wall
pushes a whisker to less than `min_contact_px` is still labelled contact (the truth is physical).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whisker.sim.effects.airflow import AirflowDrag, AirflowSpec
from whisker.coil.kinematics import marker_positions_mm, magnetic_torque, static_equilibrium, step_free, whisker_body

REST, CONTACT, DYNAMIC = 0, 1, 2     # the codes of whisker.sensing.states

DEFAULT_SEGMENTS = (("rest", 2.5), ("contact", 2.0), ("rest", 1.5), ("airflow", 3.0), ("rest", 1.5),
                    ("actuation", 1.5), ("rest", 1.5), ("contact", 2.0), ("airflow", 2.5), ("rest", 1.5))


@dataclass
class LabelledSequence:
    t_s: np.ndarray            # (T,) frame times
    dx_px: np.ndarray          # (T, n) tracked marker displacement, with noise
    dy_px: np.ndarray
    truth: np.ndarray          # (T, n) int8 REST/CONTACT/DYNAMIC
    expected_px: np.ndarray    # (T, n, 2) displacement expected from the own actuation command
    levels: np.ndarray         # (T, n) coil levels
    noise_px: np.ndarray       # (n,) the tracking noise std per whisker


def _marker_px(design, theta) -> np.ndarray:
    rest = marker_positions_mm(design, np.zeros_like(theta))
    return (marker_positions_mm(design, theta) - rest)[..., :2] / design.mm_per_px


def labelled_sequence(design, *, fps: float = 15.0, seed: int = 0, segments=DEFAULT_SEGMENTS,
                      noise_px: float = 0.3, airflow: AirflowSpec | None = None, contact_deg=(2.0, 6.0),
                      actuation_level: float = 0.5, ramp_s: float = 0.08, dt: float = 5e-4) -> LabelledSequence:
    """Simulate `segments` ((kind, seconds), ...) and sample them with a camera at `fps`."""
    from whisker.sim.contract import current_A, full_scale_voltage

    if fps <= 0 or not math.isfinite(fps):
        raise ValueError(f"fps must be > 0 (got {fps})")
    rng = np.random.default_rng(seed)
    n = design.whiskers.count
    body = whisker_body(design)
    spec = airflow or AirflowSpec(speed_m_s=8.0, turbulence=0.5, direction_deg=float(rng.uniform(0, 360)))
    wind = AirflowDrag(design, spec, seed=seed + 1)
    k_wall = 50.0 * body.stiffness
    c_wall = 2 * 0.5 * math.sqrt(k_wall * body.inertia_kgm2)
    volts = full_scale_voltage(design)

    # per-segment plans
    plans, t0 = [], 0.0
    for kind, dur in segments:
        if kind not in ("rest", "contact", "airflow", "actuation"):
            raise ValueError(f"unknown segment kind {kind!r}")
        who = np.zeros(n, dtype=bool)
        if kind in ("contact", "actuation"):
            who[rng.choice(n, size=int(rng.integers(1, max(2, n // 2 + 1))), replace=False)] = True
        psi = rng.uniform(0, 2 * math.pi, n)
        amp = np.radians(rng.uniform(*contact_deg, n))
        plans.append((kind, t0, t0 + dur, who, np.stack([np.cos(psi), np.sin(psi)], -1), amp))
        t0 += dur
    duration = t0
    I_on = np.asarray(current_A(design, np.full(n, actuation_level * volts), 20.0), dtype=float)
    theq = static_equilibrium(design, body, I_on, facing="down").theta_rad
    exp_on_px = _marker_px(design, np.stack([theq, np.zeros(n)], -1))          # (n, 2)

    frames_t = np.arange(0.0, duration, 1.0 / fps)
    T = len(frames_t)
    theta = np.zeros((n, 2))
    omega = np.zeros((n, 2))
    out_th = np.zeros((T, n, 2))
    truth = np.zeros((T, n), dtype=np.int8)
    expected = np.zeros((T, n, 2))
    levels = np.zeros((T, n))
    steps = int(math.ceil(duration / dt))
    fi = 0
    seg = 0
    for s in range(steps + 1):
        t = s * dt
        while seg + 1 < len(plans) and t >= plans[seg][2]:
            seg += 1
        kind, a, b, who, e, amp = plans[seg]
        tau = np.zeros((n, 2))
        touching = np.zeros(n, dtype=bool)
        lv = np.zeros(n)
        if kind == "contact":
            u = min((t - a) / ramp_s, 1.0, max((b - ramp_s - t) / ramp_s, 0.0) + 0.0)
            reach = amp * max(u, 0.0) - 1e-3 * (1 - max(u, 0.0))     # wall starts just clear of the tip
            proj = np.sum(theta * e, axis=1)
            pen = reach - proj
            touching = who & (pen > 0)
            f = np.where(touching, k_wall * pen - c_wall * np.sum(omega * e, axis=1), 0.0)
            tau += np.maximum(f, 0.0)[:, None] * e
        elif kind == "airflow":
            tau += wind.torque()
            wind.step(dt)
        elif kind == "actuation":
            lv = np.where(who, actuation_level, 0.0)
            tau[:, 0] += np.where(who, magnetic_torque(design, body, theta[:, 0], I_on), 0.0)
        while fi < T and frames_t[fi] <= t + 1e-12:
            out_th[fi] = theta
            truth[fi] = np.where(touching, CONTACT, DYNAMIC if kind == "airflow" else REST)
            levels[fi] = lv
            expected[fi] = np.where((lv != 0)[:, None], exp_on_px, 0.0)
            fi += 1
        theta, omega = step_free(body, theta, omega, tau, dt)
        if not np.all(np.isfinite(theta)):
            raise FloatingPointError(f"whisker tilt became non-finite at t = {t:.4f} s")
    px = _marker_px(design, out_th)
    sig = noise_px * rng.uniform(0.5, 1.5, n)
    px = px + rng.standard_normal(px.shape) * sig[None, :, None]
    return LabelledSequence(t_s=frames_t, dx_px=px[..., 0], dy_px=px[..., 1], truth=truth,
                            expected_px=expected, levels=levels, noise_px=sig)
