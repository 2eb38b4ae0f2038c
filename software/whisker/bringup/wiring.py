"""Coil wiring self-test: pulse each coil, see which marker moves and which way, fix the pin map.

``pulse_coils`` drives one whisker's channel at a time at a safe level through the thermal guard
(whisker.drive.actuation.Actuator) and tracks every marker (whisker.vision.tracking) at rest and during each
pulse: ``response[i, j]`` = mean displacement (px, image axes) of marker j while channel i is driven.
``diagnose`` reads it: the marker each channel moves (Hungarian assignment on the radial
responses, so two channels can never claim one marker), the sign (+ = outward in the image = the
whisker retracts, as a positive level should), a dead channel (no marker moves more than
``min_px``) and cross-talk (largest motion of any other marker, px). The fix is a pin-map override,
``[wiring] coil_order`` and ``coil_polarity`` (whisker.drive.pins.apply_override): whisker w is driven
through the channel that moved marker w, with forward/backward exchanged where it moved the wrong
way. ``with_override`` writes it into a copy of the design file's text.

The simulator stands in for the hardware with ``MiswiredSim``: a SimBackend behind a harness that
connects pin-map channel j to coil ``coil_of[j]`` with sign ``sign[j]`` (a dead channel drives nothing),
and ``SimCamera`` renders the simulated markers into frames for the tracker.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


class WiringError(ValueError):
    """The wiring cannot be diagnosed or fixed (a dead coil, an ambiguous response); one line."""


# ---- the simulated device: harness faults, camera, virtual clock ----------------------------------

class VirtualClock:
    """A clock for the simulator: ``sleep`` advances it, nothing waits."""

    def __init__(self, t0: float = 0.0):
        self.t = float(t0)

    def __call__(self) -> float:
        return self.t

    def sleep(self, seconds: float) -> None:
        self.t += max(float(seconds), 0.0)


def without_override(design):
    """The design with an empty pin-map override (the pin map as wired by the docs)."""
    from whisker.design import design_from_dict

    data = design.to_dict()
    data["wiring"]["coil_order"] = []
    data["wiring"]["coil_polarity"] = []
    return design_from_dict(data)


@dataclass
class Harness:
    """Physical wiring: pin-map channel j (of the design without override) reaches coil coil_of[j]
    with sign[j] (-1 = leads reversed); channels in `dead` drive nothing (open lead); `leak` stands
    for cross-talk (a neighbour's field moving another coil): coil k also gets fraction f of channel j."""
    coil_of: list
    sign: list
    dead: set = field(default_factory=set)
    leak: dict = field(default_factory=dict)   # (channel, coil) -> fraction of the channel's drive that coil also gets

    @staticmethod
    def correct(n: int) -> "Harness":
        return Harness(list(range(n)), [1] * n)


class MiswiredSim:
    """The simulator's actuation backend (whisker.drive.simulated.SimBackend) behind a faulty `harness`.

    Levels arrive per whisker; the design's pin map (with its override) says which channel and pin
    order each whisker uses; the harness says which coil that channel reaches.
    """

    def __init__(self, design, harness: Harness, **sim_kw):
        from whisker.drive.pins import pin_map
        from whisker.drive.simulated import SimBackend

        self.n = design.whiskers.count
        base = pin_map(without_override(design))
        self.route = []   # whisker i -> (channel j, pin-order sign)
        for ch in pin_map(design):
            j = next(k for k, b in enumerate(base) if {b.forward, b.backward} == {ch.forward, ch.backward}
                     and b.address == ch.address)
            self.route.append((j, 1.0 if ch.forward == base[j].forward else -1.0))
        self.harness = harness
        self.sim = SimBackend(without_override(design), **sim_kw)

    def coil_levels(self, levels) -> np.ndarray:
        out = np.zeros(self.n)
        for i, (j, s) in enumerate(self.route):
            if j not in self.harness.dead:
                lv = self.harness.sign[j] * s * float(levels[i])
                out[self.harness.coil_of[j]] += lv
                for (jj, coil), f in self.harness.leak.items():
                    if jj == j:
                        out[coil] += f * lv
        return out

    def set_levels(self, levels) -> None:
        self.sim.set_levels(self.coil_levels(np.asarray(levels, dtype=float)))

    def off(self) -> None:
        self.sim.off()

    def close(self) -> None:
        self.sim.close()

    @property
    def theta(self) -> np.ndarray:
        self.sim.sync()
        return self.sim.theta


class SimCamera:
    """Frames of the simulated markers (whisker.vision.render), noise seeded per frame."""

    def __init__(self, design, backend, noise_sigma: float = 2.0, seed: int = 0):
        self.design = design
        self.backend = backend
        self.noise = noise_sigma
        self.k = seed

    def grab(self) -> np.ndarray:
        from whisker.vision.render import marker_pixels, render_frame
        from whisker.coil.kinematics import marker_positions_mm

        px = marker_pixels(self.design, marker_positions_mm(self.design, self.backend.theta))
        self.k += 1
        return render_frame(self.design, px, seed=self.k, noise_sigma=self.noise, blur_px=0.7)


# ---- protocol -------------------------------------------------------------------------------------

DISCARD_FRAMES = 2   # frames dropped after a change: a live camera may hand out buffered, older frames


def settled_results(tracker, grab, frames: int, discard: int = DISCARD_FRAMES) -> list:
    """TrackResults of `frames` frames, after dropping `discard` (possibly buffered) ones."""
    for _ in range(discard):
        grab()
    return [tracker.track(grab()) for _ in range(frames)]


def rest_baseline(actuator, grab, tracker, *, settle_s: float, sleep, frames: int = 5):
    """Every coil off, wait `settle_s`, then the tracker's rest baseline from `frames` fresh frames."""
    actuator.neutral()
    sleep(settle_s)
    for _ in range(DISCARD_FRAMES):
        grab()
    return tracker.calibrate([grab() for _ in range(frames)])


def _mean_displacement(tracker, grab, frames: int) -> np.ndarray:
    """(N, 2) mean tracked displacement from the rest baseline over `frames` frames (NaN if never seen)."""
    d = [np.where(r.valid[:, None], np.column_stack([r.dx_px, r.dy_px]), np.nan)
         for r in settled_results(tracker, grab, frames)]
    with np.errstate(all="ignore"):
        return np.nanmean(np.array(d), axis=0)


def pulse_coils(actuator, grab, tracker, level: float, *, settle_s: float, sleep, frames: int = 3,
                rest_frames: int = 5, progress=None) -> tuple[np.ndarray, np.ndarray]:
    """Drive each whisker's channel alone at `level` (duty, + = retract) and track the markers.

    Returns (response (N, N, 2) px: [channel, marker, (dx, dy)], rest marker positions (N, 2) px).
    Every coil is off between pulses (and the whiskers back at rest after `settle_s`).
    """
    n = actuator.n
    rest_baseline(actuator, grab, tracker, settle_s=settle_s, sleep=sleep, frames=rest_frames)
    resp = np.full((n, n, 2), np.nan)
    for i in range(n):
        lv = np.zeros(n)
        lv[i] = level
        actuator.apply(lv, f"wiring {i}")
        sleep(settle_s)
        actuator.tick()
        resp[i] = _mean_displacement(tracker, grab, frames)
        actuator.neutral()
        sleep(settle_s)
        tracker.reset()
        if progress:
            progress(i)
    return resp, tracker.baseline.out_xy.copy()


@dataclass
class WiringDiagnosis:
    marker_of: list          # channel i -> marker it moves (-1: none)
    sign: list               # channel i -> +1 (moved outward = retracts) / -1 (inward) / 0
    moved_px: list           # channel i -> radial displacement of its marker, px
    crosstalk_px: list       # channel i -> largest displacement of any other marker, px
    dead: list               # channels that moved nothing
    swapped: list            # cycles of channels whose markers are permuted, e.g. [[1, 3]]
    reversed: list           # channels that moved their marker the wrong way
    crosstalk: list = field(default_factory=list)   # [channel, other marker, px] above CROSSTALK_PX

    @property
    def ok(self) -> bool:
        return not (self.dead or self.swapped or self.reversed)

    def lines(self) -> list[str]:
        out = []
        for i, (m, s, px, ct) in enumerate(zip(self.marker_of, self.sign, self.moved_px, self.crosstalk_px)):
            if m < 0:
                out.append(f"channel {i}: no marker moves (largest {ct:.2f} px): dead coil")
                continue
            way = "outward (retracts)" if s > 0 else "inward (extends)"
            note = "" if (m == i and s > 0) else "  <- " + ", ".join(
                ([f"drives whisker {m}"] if m != i else []) + (["reversed"] if s < 0 else []))
            talk = [f"marker {j} {p:.2f} px" for c, j, p in self.crosstalk if c == i]
            note += ("  <- cross-talk: " + ", ".join(talk)) if talk else ""
            out.append(f"channel {i}: marker {m} moves {abs(px):.2f} px {way}; cross-talk {ct:.2f} px{note}")
        return out

    def summary(self) -> dict:
        return {"marker_of_channel": self.marker_of, "sign": self.sign, "moved_px": self.moved_px,
                "crosstalk_px": self.crosstalk_px, "dead": self.dead, "swapped": self.swapped,
                "reversed": self.reversed, "crosstalk": self.crosstalk}


def diagnose(response, rest_xy, min_px: float = 1.0, crosstalk_px: float = 0.5) -> WiringDiagnosis:
    """Which marker each channel moves, and how (see module doc). response: (N, N, 2) px; markers other
    than a channel's own that move more than `crosstalk_px` are listed as cross-talk."""
    from scipy.optimize import linear_sum_assignment

    resp = np.asarray(response, dtype=float)
    n = resp.shape[0]
    rest = np.asarray(rest_xy, dtype=float)
    out_dir = rest - rest.mean(axis=0)
    out_dir /= np.maximum(np.linalg.norm(out_dir, axis=1, keepdims=True), 1e-9)
    radial = np.nan_to_num(np.einsum("ijk,jk->ij", resp, out_dir))
    mag = np.nan_to_num(np.linalg.norm(resp, axis=2))
    rows, cols = linear_sum_assignment(-np.abs(radial))
    marker_of, sign, moved, cross, dead = [-1] * n, [0] * n, [0.0] * n, [0.0] * n, []
    for i, j in zip(rows, cols):
        if abs(radial[i, j]) < min_px:
            dead.append(int(i))
            cross[i] = float(mag[i].max())
            continue
        marker_of[i], sign[i], moved[i] = int(j), int(np.sign(radial[i, j])), float(radial[i, j])
        others = np.delete(mag[i], j)
        cross[i] = float(others.max()) if others.size else 0.0
    # cycles of the channel -> marker permutation (a swap of two coils is a 2-cycle)
    seen, cycles = set(), []
    for i in range(n):
        if i in seen or marker_of[i] < 0 or marker_of[i] == i:
            continue
        cyc, k = [], i
        while k >= 0 and k not in seen:
            seen.add(k)
            cyc.append(k)
            k = marker_of[k]
        cycles.append(cyc)
    rev = [i for i in range(n) if sign[i] < 0]
    talk = [[int(i), int(j), float(mag[i, j])] for i in range(n) for j in range(n)
            if j != marker_of[i] and marker_of[i] >= 0 and mag[i, j] > crosstalk_px]
    return WiringDiagnosis(marker_of, sign, moved, cross, sorted(dead), cycles, rev, talk)


def override_for(design, diag: WiringDiagnosis) -> tuple[list[int], list[int]]:
    """(coil_order, coil_polarity) that make positive levels retract every whisker, composed with the
    design's current override (the diagnosis was made through it)."""
    if diag.dead:
        raise WiringError(f"coil channel(s) {diag.dead} moved no marker (dead coil, open lead or no supply); "
                          "fix the hardware, no override written")
    n = len(diag.marker_of)
    order0 = list(design.wiring.coil_order) or list(range(n))
    pol0 = list(design.wiring.coil_polarity) or [1] * n
    chan_of_marker = {m: i for i, m in enumerate(diag.marker_of)}
    order = [order0[chan_of_marker[w]] for w in range(n)]
    pol = [pol0[chan_of_marker[w]] * diag.sign[chan_of_marker[w]] for w in range(n)]
    return order, pol


def with_override(toml_text: str, order, polarity) -> str:
    """The design file's text with [wiring] coil_order / coil_polarity set (other lines untouched)."""
    from whisker.design.edit import set_keys

    return set_keys(toml_text, "wiring", {"coil_order": f"[{', '.join(str(int(v)) for v in order)}]",
                                          "coil_polarity": f"[{', '.join(str(int(v)) for v in polarity)}]"},
                    "pin-map override written by `whisker calibrate wiring`")
