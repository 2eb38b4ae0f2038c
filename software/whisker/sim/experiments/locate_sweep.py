"""Simulated contact-distance sweeps for whisker.sensing.locate, with the truth known (issue 31).

Why not the MuJoCo scene: whisker.sim.mj models each whisker as a RIGID rod on two hinges, and its
rod contacts are MuJoCo's rigid (mass-normalised) constraints, so a rod held at any distance stops
the base the same way: the information the active sweep reads (the rod's bending between pivot and
contact) is absent there by construction. This module is the quasi-static model of that situation:

- the whisker: base tilt theta (2 axes, rad) on the membrane (k, N*mm/rad per axis), coil torque tau
  about the radial axis (whisker.sensing.locate.coil_torque_Nmm), the rod an Euler-Bernoulli beam (EI)
  from the pivot to the contact at r;
- the object: a surface whose normal n makes ``approach_deg`` with the sweep axis, pushing the rod
  with a normal force N >= 0 and a Coulomb friction T (|T| <= mu N, ``contact.rod_friction`` of the
  scene model: the contact is on the bare carbon rod); rigid, or compliant by Hertz
  (whisker.sim.effects.contact_law) with a material of scenes/materials.toml against the rod;
- moment balance tau e + r f - k theta = 0, contact point u = r theta + f r^3/(3 EI) (beam),
  normal: n.u = g - delta(N) (g from the preload), tangential: stick at the last position or slide
  with |T| = mu N, frame after frame (path dependent);
- the camera: the tilt sequence goes through rendered frames and the real tracker
  (`render_and_track`: whisker.vision.render + whisker.vision.tracking, method ``fit``, the scene
  camera's default noise and blur),
  or, for large studies, through a bank of the tracker's errors measured the same way on rendered
  frames (`tracker_noise_bank`, resampled per sweep).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from whisker.sensing import locate as L

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

MATERIALS = Path(__file__).resolve().parents[1] / "scenes" / "materials.toml"
#: mm, radius of curvature of the objects' surfaces where the rod touches (a 40 mm fruit / ball)
OBJECT_RADIUS_MM = 20.0


def rod_friction() -> float:
    """The bare rod's Coulomb coefficient: the scene model's default ``contact.rod_friction``."""
    from whisker.sim.scene import ContactSpec

    return float(ContactSpec.model_fields["rod_friction"].default)


def material(name: str) -> dict:
    """Young's modulus (Pa), Poisson ratio and source of a material in scenes/materials.toml."""
    mats = tomllib.loads(MATERIALS.read_text(encoding="utf-8"))["materials"]
    if name not in mats:
        raise ValueError(f"unknown material {name!r}; {MATERIALS.name} has {', '.join(mats)}")
    m = mats[name]
    return {"E_Pa": float(m["youngs_modulus_Pa"]), "nu": float(m["poisson"]), "source": m.get("source", "")}


def hertz_compliance(design, material_name: str | None, object_radius_mm: float = OBJECT_RADIUS_MM):
    """(indentation(N) mm, d indentation / dN mm/N) of the rod (rigid) pressed into the material, or
    None for a rigid object. Hertz: F = 4/3 E* sqrt(R) delta^1.5, 1/R = 1/R_rod + 1/R_object."""
    if material_name is None:
        return None
    from whisker.sim.effects.contact_law import effective_modulus_Pa, effective_radius_m

    m = material(material_name)
    E_star = effective_modulus_Pa(m["E_Pa"], m["nu"], math.inf, 0.0)
    R = effective_radius_m(design.whiskers.rod_diameter / 2 * 1e-3, object_radius_mm * 1e-3)
    scale = 3.0 / (4.0 * E_star * math.sqrt(R))          # contact_law.hertz_indentation_m, inlined (per frame)

    def delta(F_N):
        return 1e3 * (scale * max(F_N, 0.0)) ** (2.0 / 3.0)

    def slope(F_N):
        F = max(F_N, 1e-6)
        return (2.0 / 3.0) * delta(F) / F

    return delta, slope


@dataclass(frozen=True)
class Case:
    r_mm: float
    material: str | None = None       # None = rigid
    approach_deg: float = 0.0
    preload_deg: float = 2.0          # base tilt the object pushed the whisker to before the sweep
    mu: float | None = None           # None = rod_friction()


def response(design, case: Case, tau_Nmm: np.ndarray, k: float | None = None, EI: float | None = None
             ) -> np.ndarray:
    """(F, 2) exact [radial, tangential] tilt (rad) for the torque sequence (N*mm), quasi-static."""
    tau = np.asarray(tau_Nmm, dtype=float)
    return _respond(design, case, len(tau), lambda i, theta_r: tau[i], k, EI)


def _respond(design, case: Case, frames: int, torque_at, k=None, EI=None, tol: float = 0.0,
             max_iter: int = 1) -> np.ndarray:
    """The frame-by-frame contact model (module docstring); torque_at(i, radial tilt) gives frame i's
    torque (N*mm). With ``max_iter`` > 1 each frame's torque and tilt are iterated to their fixed point
    (to ``tol`` rad) before the contact's stick position is carried to the next frame."""
    k = L.membrane_stiffness_Nmm_per_rad(design)[0] if k is None else k
    EI = L.bending_stiffness_Nmm2(design) if EI is None else EI
    mu = rod_friction() if case.mu is None else case.mu
    r = case.r_mm
    e = np.array([1.0, 0.0])
    phi = math.radians(case.approach_deg)
    n = -np.array([math.cos(phi), math.sin(phi)])       # the object pushes the rod back from the sweep
    t_hat = np.array([-n[1], n[0]])
    Cb = r * r / k + r ** 3 / (3 * EI)                   # contact-point compliance of membrane + beam, mm/N
    hz = hertz_compliance(design, case.material)
    delta = (lambda F: 0.0) if hz is None else hz[0]
    N0 = k * math.radians(case.preload_deg) / r
    g = N0 * Cb + delta(N0)

    def step(tau, s):
        rhs = g - r * tau * float(e @ n) / k             # N Cb + delta(N) = rhs, monotone in N
        if rhs <= 0:
            N = 0.0
        elif hz is None:
            N = rhs / Cb
        else:
            lo, hi = 0.0, rhs / Cb
            for _ in range(40):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if mid * Cb + delta(mid) < rhs else (lo, mid)
            N = 0.5 * (lo + hi)
        free_t = r * tau * float(e @ t_hat) / k
        T = (s - free_t) / Cb
        if abs(T) > mu * N:
            T = math.copysign(mu * N, T)
            s = free_t + T * Cb
        f = N * n + T * t_hat
        return (tau * e + r * f) / k, s

    s = 0.0                                              # tangential stick position of the contact point
    out = np.zeros((frames, 2))
    theta_r = 0.0
    for i in range(frames):
        for it in range(max_iter):
            theta, s_new = step(float(torque_at(i, theta_r)), s)
            done = abs(theta[0] - theta_r) < tol
            theta_r = float(theta[0])
            if done:
                break
        else:
            if max_iter > 1:
                raise RuntimeError(f"{case}: coil torque and tilt have no equilibrium near frame {i}'s tilt ({max_iter} "
                                   "iterations): the coil's pull grows with the tilt faster than the sliding contact "
                                   "and the membrane resist, the whisker would snap to its stop (not modelled)")
        out[i], s = theta, s_new
    return out


#: rad, each frame's coil-torque / tilt fixed point in `sweep_tilt` is iterated to this
SWEEP_TOL_RAD = 1e-12


def sweep_tilt(design, case: Case, levels: np.ndarray, max_iter: int = 50) -> np.ndarray:
    """(F, 2) exact tilt (rad) for a sequence of coil levels: the coil's torque depends on the tilt (the
    magnet-coil gap) and the tilt on the torque, so each frame is iterated to their fixed point (to
    SWEEP_TOL_RAD) before the contact's slide state goes on to the next frame (the contact is path
    dependent: iterating whole sequences instead can cycle between slide states). A sliding contact
    moves the base by up to ~0.1 rad, where the torque changes by more than the rod's bending signal."""
    levels = np.asarray(levels, dtype=float)
    return _respond(design, case, len(levels),
                    lambda i, theta_r: L.coil_torque_Nmm(design, levels[i:i + 1], np.array([theta_r]))[0],
                    tol=SWEEP_TOL_RAD, max_iter=max_iter)


#: the tracker method: the sub-pixel fit (docs/tracking.md: ~30 % less displacement noise than roi)
METHOD = "fit"


def tracker_noise_bank(design, frames: int = 200, whisker: int = 0, noise_sigma: float = 2.0,
                       blur_px: float = 0.8, seed: int = 0) -> np.ndarray:
    """(frames, 2) tracked tilt error (rad, [radial, tangential]) of one whisker on rendered rest frames
    through the real tracker (the scene camera's default noise and blur)."""
    zero = np.zeros((frames, 2))
    return render_and_track(design, whisker, zero, noise_sigma=noise_sigma, blur_px=blur_px, seed=seed, zero_frames=0)


def render_and_track(design, whisker: int, tilt_rad: np.ndarray, noise_sigma: float = 2.0, blur_px: float = 0.8,
                     seed: int = 0, progress=None, method: str = METHOD, zero_frames: int = 30) -> np.ndarray:
    """Render one frame per tilt (the other whiskers at rest), track it, return the tracked tilt (F, 2).

    ``zero_frames`` rest frames are tracked first the same way and their mean tilt is the zero: the
    free whisker's rest recorded by the tracking method itself before the contact, as a live sensor
    would. The tracker's rest calibration now locates the markers with the tracking method too (it used
    the detector's centroids, ~1e-4 rad off the ``fit`` frames); the zero frames also average out the
    5-frame calibration's noise, which the cone-edge estimate of a sliding contact
    (whisker.sensing.contact_slip) would read as absolute tilt."""
    from whisker.coil.kinematics import marker_positions_mm
    from whisker.vision.render import marker_pixels, render_frame
    from whisker.vision.tracking import Tracker

    n = design.whiskers.count
    rest = marker_pixels(design, marker_positions_mm(design, np.zeros((n, 2))))
    trk = Tracker(design, method=method)
    trk.calibrate([render_frame(design, rest, seed=seed * 1000 + 999_000 + j, noise_sigma=noise_sigma,
                                blur_px=blur_px) for j in range(5)])
    def tracked(th, frame_seed):
        theta = np.zeros((n, 2))
        theta[whisker] = th
        img = render_frame(design, marker_pixels(design, marker_positions_mm(design, theta)),
                           seed=frame_seed, noise_sigma=noise_sigma, blur_px=blur_px)
        res = trk.track(img)
        if not res.valid[whisker]:
            return np.full(2, np.nan)
        geo = trk.deflection(res, model="exact")          # the camera's exact ray model: absolute tilt
        return L.tilt_from_tip_mm(design, whisker, np.array([[geo.tip_x_mm[whisker], geo.tip_y_mm[whisker]]]))[0]

    zero = np.zeros(2)
    if zero_frames:
        z = np.array([tracked(np.zeros(2), seed * 1000 + 998_000 + j) for j in range(zero_frames)])
        zero = np.nanmean(z, axis=0) if np.isfinite(z).any() else zero
    out = np.full((len(tilt_rad), 2), np.nan)
    for f, th in enumerate(np.asarray(tilt_rad, dtype=float)):
        out[f] = tracked(th, seed * 1000 + f) - zero
        if progress and f % 20 == 0:
            progress(f / len(tilt_rad))
    return out


def run_case(design, case: Case, *, amplitude: float = L.DEFAULT_AMPLITUDE, duration_s: float = L.DEFAULT_DURATION_S,
             fps: float = 30.0, period_s: float = L.DEFAULT_PERIOD_S, noise: np.ndarray | None = None,
             frames: bool = False, rng=None, seed: int = 0, sweep: bool = True, known_compliance: bool = False,
             rigid_object: bool = True, mu: float | None = None):
    """One simulated sweep -> whisker.sensing.locate.estimate. ``noise``: a tracker-error bank resampled
    onto the frames; ``frames=True``: render and track every frame instead. ``sweep=False``: the
    same frames with the coil off (the ablation). ``rigid_object`` False: the estimator is told the
    object's compliance is unknown; ``mu``: the friction coefficient the estimator is given to locate a
    contact that slides every cycle at its cone's edge (opt-in; None: such a contact gets "slip"). Returns (LocateResult, truth dict)."""
    t, lev = L.sweep_levels(amplitude if sweep else 0.0, duration_s, fps, period_s)
    tilt = sweep_tilt(design, case, lev)
    if frames:
        obs = render_and_track(design, 0, tilt, seed=seed)
    else:
        rng = np.random.default_rng(seed) if rng is None else rng
        obs = tilt + noise[rng.integers(len(noise), size=len(t))]
    comp = None
    if known_compliance and case.material is not None:
        comp = hertz_compliance(design, case.material)[0]
    try:
        res = L.estimate(design, L.Sweep(t, lev, obs), contact_indentation_mm=comp, rigid_object=rigid_object,
                         mu=mu)
    except L.LocateError as err:
        res = L.LocateResult("refused", str(err), frames=len(t))
    k = L.membrane_stiffness_Nmm_per_rad(design)[0]
    truth = {"r_mm": case.r_mm, "force_mN": 1e3 * k * math.radians(case.preload_deg) / case.r_mm}
    return res, truth


#: px, a 32-frame window whose std (both axes) is below this counts as "at rest" in the authors' series
QUIET_STD_PX = 0.25
QUIET_WINDOW = 32


def peer_jitter_series(design, path=None) -> tuple[np.ndarray, float]:
    """((n, 2) tilt noise in rad [radial, tangential], frame rate Hz): the authors' REAL tracked marker
    jitter while the whisker stands still (their camera, lighting, vibration and tracker together).

    Source: airflow/airflowDemoData.csv of the authors' data (WHISKER_PEER_DATA; 2337 frames at ~65 fps
    of one whisker's marker displacement, px). The quiet runs (every 32-frame window's std below
    QUIET_STD_PX on both axes, the rest/hold periods between air puffs; QUIET_WINDOW / 4 frames trimmed
    off each end) are kept, each run minus its own mean, in time order (so the spectrum is the measured one), and converted px -> rad by the design's
    marker lever (l_l / mm_per_px px per rad: a marker displacement of 1 px is that tilt). Their dx is
    taken as radial and dy as tangential (both have the same spread)."""
    import os

    if path is None:
        root = os.environ.get("WHISKER_PEER_DATA")
        if not root:
            raise FileNotFoundError("the authors' real jitter needs WHISKER_PEER_DATA (their data folder)")
        path = Path(root) / "airflow" / "airflowDemoData.csv"
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    t, xy = data[:, 0], data[:, 1:3]
    n = len(t)
    quiet = np.zeros(n, bool)
    for i in range(n - QUIET_WINDOW + 1):
        if (xy[i:i + QUIET_WINDOW].std(axis=0) < QUIET_STD_PX).all():
            quiet[i:i + QUIET_WINDOW] = True
    edges = np.flatnonzero(np.diff(np.r_[0, quiet.astype(int), 0]))
    trim = QUIET_WINDOW // 4          # a window that only starts to catch a movement can still pass: drop run ends
    runs = [xy[a + trim:b - trim] - xy[a + trim:b - trim].mean(axis=0)
            for a, b in zip(edges[::2], edges[1::2]) if b - a >= 2 * QUIET_WINDOW + 2 * trim]
    if not runs:
        raise ValueError(f"{path}: no still period of {2 * QUIET_WINDOW} frames found")
    px_per_rad = design.derived()["l_l_mm"] / design.derived()["mm_per_px"]
    fps = 1.0 / float(np.median(np.diff(t)))
    return np.concatenate(runs) / px_per_rad, fps


def draw_noise(bank: np.ndarray, n: int, rng, block: int | None = None) -> np.ndarray:
    """(n, 2) noise drawn from a bank: frame by frame (``block`` None: white, for the rendered-frame bank
    whose frames are independent) or as a moving-block bootstrap of ``block`` consecutive frames
    (Kuensch 1989), which keeps the measured series' short-range correlation and so its spectrum."""
    if block is None:
        return bank[rng.integers(len(bank), size=n)]
    starts = rng.integers(len(bank) - block, size=n // block + 1)
    return np.concatenate([bank[s:s + block] for s in starts])[:n]
