"""Where the object sits between the whiskers at the grip: active-whisking contact distance in the
simulated closed-loop grasp (issue 31; whisker.sensing.locate).

When the closed-loop controller decides it holds the object (its first ``lift`` command), every
holding whisker touches the object somewhere along its rod. On the hardware the controller would then
run one locate sweep on a holding whisker (whisker.sensing.locate_live) and know how far along the rods
the object sits. The MuJoCo grasp scene cannot produce that sweep's signal: its rods are rigid (see
whisker.sim.experiments.locate_sweep), so the sweep is simulated the way the locate benchmark does it:
the contact distance MuJoCo reports for the whisker (the truth) goes into the quasi-static membrane +
beam model (locate_sweep.response, rigid object, stick), the camera's error is added (a tracker-error
bank: rendered frames through the real tracker, or the authors' real jitter) and locate.estimate reads
it. Each attempt thus reports, per holding whisker, the true and the estimated distance.

`GripLocator` is an ``on_frame`` hook for closed_loop.run_grasp; nothing in the grasp changes.
"""

from __future__ import annotations

import math

import numpy as np

from whisker.sensing import locate as L
from whisker.sim.experiments import locate_sweep as S


def contact_distances_mm(rig) -> np.ndarray:
    """(n,) distance (mm) from each whisker's pivot, along its rod, of its contacts with the object
    (mean over the contacts; NaN: not touching). MuJoCo contact positions in the rod body's frame,
    whose origin is the pivot and whose z runs along the rod."""
    d, m = rig.sim.data, rig.sim.model
    acc = [[] for _ in range(rig.n)]
    for c in d.contact[:d.ncon]:
        for a, b in ((c.geom1, c.geom2), (c.geom2, c.geom1)):
            if a in rig._whisker_geom and b != rig._table and b not in rig._whisker_geom:
                body = m.geom_bodyid[a]
                local = d.xmat[body].reshape(3, 3).T @ (np.asarray(c.pos) - d.xpos[body])
                acc[rig._whisker_geom[a]].append(1e3 * float(local[2]))
    return np.array([np.mean(v) if v else math.nan for v in acc])


class GripLocator:
    """on_frame hook: at the grip, the true contact distances of the holding whiskers; `rows()` the
    locate estimate for each (the default sweep, `noise` a (F, 2) tilt-error bank in rad)."""

    def __init__(self, design, noise: np.ndarray, *, block: int | None = None, fps: float = 120.0, seed: int = 0):
        self.design, self.noise, self.block, self.fps, self.seed = design, noise, block, fps, seed
        self.truth_mm: np.ndarray | None = None
        self.holding: list[int] = []

    def __call__(self, rig, controller, cmd) -> None:
        if self.truth_mm is None and cmd.phase == "lift":
            self.truth_mm = contact_distances_mm(rig)
            hold = getattr(getattr(controller, "est", None), "contact", None)
            self.holding = [int(w) for w in (np.flatnonzero(hold) if hold is not None else [])]

    def rows(self) -> list[dict]:
        if self.truth_mm is None:
            return []
        out = []
        L_mm = float(self.design.whiskers.protrusion)
        for w in self.holding:
            r = float(self.truth_mm[w])
            if L_mm < r <= L_mm + float(self.design.whiskers.rod_diameter):
                r = L_mm                          # on the tip's rounded end (the capsule's cap)
            if not (math.isfinite(r) and 0.5 < r <= L_mm):
                out.append({"whisker": w, "truth_mm": None if not math.isfinite(r) else round(r, 2),
                            "status": "no contact", "distance_mm": None, "distance_sigma_mm": None})
                continue
            rng = np.random.default_rng([self.seed, w])
            t, lev = L.sweep_levels(L.DEFAULT_AMPLITUDE, L.DEFAULT_DURATION_S, self.fps)
            tilt = np.zeros((len(t), 2))
            for _ in range(3):
                tilt = S.response(self.design, S.Case(r), L.coil_torque_Nmm(self.design, lev, tilt[:, 0]))
            obs = tilt + S.draw_noise(self.noise, len(t), rng, self.block)
            try:
                res = L.estimate(self.design, L.Sweep(t, lev, obs))
                row = res.row()
            except L.LocateError as err:
                row = {"status": "refused", "message": str(err), "distance_mm": None, "distance_sigma_mm": None}
            out.append({"whisker": w, "truth_mm": round(r, 2), "status": row["status"],
                        "distance_mm": row["distance_mm"], "distance_sigma_mm": row.get("distance_sigma_mm")})
        return out


def summary(rows: list[dict]) -> str:
    """One cell for a table: w3 31.2+-1.1 (30.4); 'no grip' when empty."""
    if not rows:
        return "no grip"
    return "; ".join(f"w{r['whisker']} " + (f"{r['distance_mm']:.1f}+-{r['distance_sigma_mm']:.1f}"
                                            if r["distance_mm"] is not None else r["status"])
                     + (f" ({r['truth_mm']:.1f})" if r["truth_mm"] is not None else "") for r in rows)
