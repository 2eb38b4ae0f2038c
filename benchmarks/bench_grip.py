"""The grip behind the grasp table (docs/sim.md, "Why two whiskers hold nothing"): one centred attempt
per object with two and with four whiskers, rigid and compliant contact. Per cell: the radial tilt of
the driven whiskers at the end of closing, the normal force each tip presses with, the object's
weight, its friction against the tips, the friction a lift by friction alone would need, and what the
object did (highest rise, end height).

Normal force per tip, mN: N = (tau_coil(theta, I(T)) + tau_gravity(theta) - k theta) / l_u, the
coil torque at the tilt where the tip meets the object (whisker.coil.kinematics.magnetic_torque, the
current at the coil's temperature at that moment, whisker.drive.guard via the contract), minus the membrane
spring, over the pivot-to-tip lever l_u. A lift by friction alone needs mu sum(N) >= m g over the
driven tips, so mu_needed = m g / sum(N) (a tip at or past its free tilt presses nothing).

Writes benchmarks/results/sim_grip.md atomically. Run: .venv/bin/python benchmarks/bench_grip.py
(part of make bench; about 30 s).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from common import RESULTS, machine_line  # noqa: E402

from whisker.files import atomic_write_text  # noqa: E402
from whisker.mechanics.membrane import design_stiffness_Nmm_per_rad  # noqa: E402
from whisker.sim import load_scene, scene_design  # noqa: E402
from whisker.sim.experiments import paper  # noqa: E402
from whisker.sim.contract import current_A, full_scale_voltage  # noqa: E402
from whisker.coil.kinematics import gravity_torque, magnetic_torque, static_equilibrium, whisker_body  # noqa: E402
from whisker.sim.protocol import T_CLOSE, T_DOWN, Placement  # noqa: E402
from whisker.sim.scene import scene_with_overrides  # noqa: E402

SCENE = ROOT / "software" / "whisker" / "sim" / "scenes" / "grasp.toml"
G = 9.81  # m/s^2


def tip_force_mN(design, body, theta_rad, current) -> np.ndarray:
    """Normal force of a tip held at radial tilt theta (rad) with coil current I (A), mN."""
    tau = magnetic_torque(design, body, theta_rad, current) + gravity_torque(body, theta_rad) - body.stiffness * theta_rad
    return np.asarray(tau, dtype=float) / body.tip_m * 1e3


def main() -> None:
    base = load_scene(SCENE)
    design = scene_design(base)
    body = whisker_body(design)
    volts = paper.grasp_level(design) * full_scale_voltage(design)
    i20 = float(current_A(design, volts, 20.0))
    free = math.degrees(float(static_equilibrium(design, body, np.array([i20])).theta_rad[0]))
    lines = ["# The grip behind the grasp table: tip force, weight, friction needed\n",
             f"Machine: {machine_line()}. Scene `grasp.toml`, design `hw/sensor.toml`: coil {design.coil.turns} turns, "
             f"{design.coil.resistance:.2f} ohm (whisker.design.former), membrane k = {design_stiffness_Nmm_per_rad(design):.4g} N mm/rad, "
             f"grasp at {volts:.2f} V (level {paper.grasp_level(design):.3f}), {i20 * 1e3:.0f} mA at 20 C; "
             f"pivot-to-tip lever {body.tip_m * 1e3:.1f} mm; free tilt (sensor facing down, no object) {free:.2f} deg.\n",
             "Normal force per tip N = (coil torque + gravity torque - k theta) / l_u at the tilt where the tip meets the "
             "object; a lift by friction alone needs mu sum N >= m g "
             "(sum over the driven tips; a tip at or past its free tilt presses nothing).\n",
             "| tilt (deg) | " + " | ".join(f"{a:g}" for a in (0, 1, 2, 3, 4, 6, 8)) + " |",
             "| --- |" + " --- |" * 7,
             "| N per tip (mN), coil at 20 C | " + " | ".join(
                 f"{float(tip_force_mN(design, body, math.radians(a), i20)):.2f}" for a in (0, 1, 2, 3, 4, 6, 8)) + " |\n",
             "Centred attempt (no placement noise), the driven whiskers at the end of closing:\n",
             "| object | contact | whiskers | grip tilt (deg) | N per tip (mN) | weight (mN) | mu (pair) | mu needed, m g / sum N "
             "| highest rise (mm) | held |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for comp in ("off", "auto"):
        sc = scene_with_overrides(base, [f"fidelity.compliance={comp}"])
        cfgs = paper.configurations(sc, design)[1:]              # every second (4 of 8), opposite pair (2)
        for o in paper.experiment_objects(sc):
            for active in cfgs:
                a = paper.grasp_attempt(sc, design, o, active, body=body, placement=Placement(), keep=True)
                r = a.result
                k = min(int(np.searchsorted(r.t_s, T_DOWN + T_CLOSE - 1e-9)), len(r.t_s) - 1)
                th = r.theta_rad[k, active, 0]
                temp = r.temperature_C[k, active] if r.temperature_C is not None else np.full(len(active), 20.0)
                n_mN = tip_force_mN(design, body, th, np.asarray(current_A(design, volts, temp), dtype=float))
                w_mN = o.mass * 1e-3 * G * 1e3
                mu = o.friction if o.friction is not None else design.mechanics.tip_friction
                n_sum = float(np.sum(np.maximum(n_mN, 0.0)))       # a tip past its free tilt presses nothing
                need = f"{w_mN / n_sum:.2f}" if n_sum > 0.05 else "- (tips at their free tilt)"
                z = r.objects_mm[:, 0, 2]
                deg = np.degrees(th)
                span = lambda a, f: f"{a.min():{f}}" if f"{a.min():{f}}" == f"{a.max():{f}}" else f"{a.min():{f}} to {a.max():{f}}"
                lines.append(f"| {o.name} | {'rigid' if comp == 'off' else 'compliant'} | {len(active)} | "
                             f"{span(deg, '.1f')} | {span(n_mN, '.2f')} | {w_mN:.2f} | {mu:g} | "
                             f"{need} | {float(z.max() - z[0]):.2f} | {'yes' if a.success else 'no'} |")
                print(lines[-1], flush=True)
    lines.append("")
    atomic_write_text(RESULTS / "sim_grip.md", "\n".join(lines))
    print("\n".join(lines[:6]))


if __name__ == "__main__":
    main()
