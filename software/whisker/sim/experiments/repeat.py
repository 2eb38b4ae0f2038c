"""The paper's experiments as repeated scenes (pure: each returns tables and arrays; I/O in run/CLI).

- ``angle_vs_voltage`` (Fig. 4): static equilibrium tilt against coil voltage, both polarities.
- ``grasp`` (Table I): descend until the tips are `tip_height` mm above the table, actuate the
  configuration, lift, hold; success if the object ends above `hold_height`. Attempts with
  placement noise, per object and configuration.
- ``displacement`` (Fig. 8): marker displacement against time during the 8-whisker grasp, mean
  and band over trials.
- ``classification`` (Section III-A): approaches from 4 directions x 2 distances x rotations x
  trials; each sample = 8 records x N whiskers x (dx, dy) pixel displacements of the markers
  (128 values for N = 8), one row per sample in ``<object>.csv`` (the authors' layout).
"""

from __future__ import annotations

import math

import numpy as np

from whisker.sim.scene import Scene, SceneError

# The paper's grasp success rates (%), Table I (DESIGN.md section 1): object -> (8, 4, 2 whiskers).
PAPER_GRASP = {
    "paper flower": (70, 35, 20),
    "pom-pom": (100, 100, 65),
    "mini pinecone": (80, 50, 30),
    "popcorn": (85, 35, 10),
    "foam ball": (100, 50, 30),
}
PAPER_GRASP_TOTAL = (87, 54, 31)


def angle_vs_voltage(scene: Scene, design) -> dict:
    """Equilibrium radial tilt (deg) of one whisker against coil voltage (V), Fig. 4 shape."""
    from whisker.sim.contract import current_A
    from whisker.coil.kinematics import static_equilibrium, whisker_body

    volts = np.asarray(scene.experiment.voltages or np.linspace(-3, 3, 13), dtype=float)
    body = whisker_body(design)
    I = current_A(design, volts)
    eq = static_equilibrium(design, body, I, facing=scene.sensor.facing, model=scene.fidelity.magnetics)
    return {"volts": volts, "current_A": np.asarray(I), "theta_deg": np.degrees(eq.theta_rad),
            "at_stop": eq.at_stop}


def angle_table(res: dict) -> str:
    lines = ["| coil voltage (V) | current (A) | tilt (deg, + retract) | at stop |", "| --- | --- | --- | --- |"]
    for v, i, th, s in zip(res["volts"], res["current_A"], res["theta_deg"], res["at_stop"]):
        lines.append(f"| {v:+.2f} | {i:+.3f} | {th:+.2f} | {'yes' if s else ''} |")
    return "\n".join(lines) + "\n"


def plot_angle_vs_voltage(res: dict, path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.plot(res["volts"], res["theta_deg"], "o-")
    stop = res["at_stop"]
    if np.any(stop):
        ax.plot(res["volts"][stop], res["theta_deg"][stop], "rx", label="at the stop")
        ax.legend()
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel("coil voltage (V)")
    ax.set_ylabel("whisker tilt (deg, + retraction)")
    ax.set_title("Simulated angle vs voltage (paper Fig. 4 shape)")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
