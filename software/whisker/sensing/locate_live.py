"""Active-whisking contact distance inside a frame stream (`whisker live --locate`, the grasp).

`LiveLocator` watches the live pipeline's states. When a whisker has been labelled "contact" for
`settle_frames` frames in a row (or the chosen whisker has), it drives that whisker's coil through the
square-wave sweep of whisker.sensing.locate (one level per camera frame), collects the tracked tilt of
every frame of the sweep, switches the coil off and hands the sweep to `locate.estimate`: the contact
distance (mm from the pivot) and force (mN), or a status without a number ("no contact", "not
observable", "slip", "slip or soft contact"); with the rod's friction coefficient (``mu``) a contact
that slides every cycle is located at its friction cone's edge (whisker.sensing.contact_slip). A stream that ends with no whisker in contact gives "no contact".
The sweep is checked against the thermal limit before anything moves (`locate.check_sweep`).

The level recorded for a frame is the one in force while the frame was exposed: the level set after
the previous frame (the caller applies `next_levels()` before grabbing the next frame).
"""

from __future__ import annotations

import numpy as np

from whisker.sensing import locate as L
from whisker.sensing.states import CONTACT


class LiveLocator:
    """One sweep per contact episode. `whisker` None: the first whisker that settles in contact."""

    def __init__(self, design, *, whisker: int | None = None, amplitude: float | None = None,
                 duration_s: float | None = None, fps: float = 30.0, settle_frames: int = 5,
                 start_C: float | None = None, mu: float | None = None):
        self.design = design
        self.mu = mu                               # rod-object Coulomb coefficient (locate.estimate)
        self.n = design.whiskers.count
        if whisker is not None and not 0 <= whisker < self.n:
            raise L.LocateError(f"whisker {whisker} is not one of the design's 0-{self.n - 1}")
        self.whisker = whisker
        self.amplitude = L.DEFAULT_AMPLITUDE if amplitude is None else float(amplitude)
        self.duration_s = L.DEFAULT_DURATION_S if duration_s is None else float(duration_s)
        self.heat = L.check_sweep(design, self.amplitude, self.duration_s, start_C)     # refuses past the limit
        self.t_plan, self.lev_plan = L.sweep_levels(self.amplitude, self.duration_s, fps)
        if len(self.lev_plan) < L.MIN_FRAMES:
            raise L.LocateError(f"a {self.duration_s:g} s sweep at {fps:g} fps has {len(self.lev_plan)} frames, "
                                f"need at least {L.MIN_FRAMES}")
        self.settle_frames = int(settle_frames)
        self._run = np.zeros(self.n, int)          # consecutive contact frames per whisker
        self.active: int | None = None            # whisker being swept
        self._i = 0                               # next sweep frame
        self._level_now = 0.0                     # level in force for the next frame
        self._t, self._lev, self._tilt, self._ok = [], [], [], []
        self.results: list[dict] = []

    @property
    def sweeping(self) -> bool:
        return self.active is not None

    def next_levels(self) -> np.ndarray | None:
        """Coil levels (n,) to apply before the next frame, or None when not sweeping."""
        if self.active is None:
            return None
        out = np.zeros(self.n)
        out[self.active] = self._level_now
        return out

    def update(self, live, tracker) -> dict | None:
        """Feed one LiveFrame (and the tracker that made it). Returns the locate record when a sweep
        has just finished, else None."""
        if self.active is None:
            contact = np.asarray(live.labels) == CONTACT
            self._run = np.where(contact, self._run + 1, 0)
            ready = [w for w in (range(self.n) if self.whisker is None else [self.whisker])
                     if self._run[w] >= self.settle_frames]
            if ready:
                self.active, self._i = ready[0], 0
                self._t, self._lev, self._tilt, self._ok = [], [], [], []
                self._level_now = float(self.lev_plan[0])
            return None
        w = self.active
        geo = tracker.deflection(live.result)
        tip = np.array([[geo.tip_x_mm[w], geo.tip_y_mm[w]]], dtype=float)
        ok = bool(live.valid[w]) and bool(np.isfinite(tip).all())
        self._t.append(float(live.time_s))
        self._lev.append(self._level_now)
        self._tilt.append(L.tilt_from_tip_mm(self.design, w, np.nan_to_num(tip))[0] if ok else [np.nan, np.nan])
        self._ok.append(ok)
        self._i += 1
        if self._i < len(self.lev_plan):
            self._level_now = float(self.lev_plan[self._i])
            return None
        self.active, self._level_now = None, 0.0
        self._run[:] = -10 ** 9       # one sweep per contact episode: the count restarts from 0 once contact ends
        return self._finish(w)

    def _finish(self, w: int) -> dict:
        sweep = L.Sweep(np.array(self._t), np.array(self._lev), np.array(self._tilt, dtype=float),
                        np.array(self._ok, bool))
        try:
            res = L.estimate(self.design, sweep, mu=self.mu)
            row = res.row()
        except L.LocateError as err:
            row = {"status": "refused", "message": str(err), "distance_mm": None, "force_mN": None}
        rec = {"whisker": w, **row, "sweep_level": self.amplitude, "sweep_s": self.duration_s,
               "coil_rise_K": round(self.heat["rise_K"], 2)}
        self.results.append(rec)
        return rec

    def finish(self) -> dict | None:
        """At the end of the stream: "no contact" if no sweep ran; None otherwise (or mid-sweep: a
        sweep cut short is reported as such, without a number)."""
        if self.active is not None:
            rec = {"whisker": self.active, "status": "refused", "distance_mm": None, "force_mN": None,
                   "message": f"the stream ended {self._i} frames into a {len(self.lev_plan)}-frame sweep"}
            self.results.append(rec)
            return rec
        if self.results:
            return None
        which = "no whisker" if self.whisker is None else f"whisker {self.whisker}"
        rec = {"whisker": self.whisker, "status": "no contact", "distance_mm": None, "force_mN": None,
               "message": f"{which} was in contact for {self.settle_frames} frames: nothing to locate"}
        self.results.append(rec)
        return rec
