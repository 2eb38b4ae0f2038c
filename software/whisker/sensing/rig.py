"""The closed-loop grasp on real hardware: camera frames -> tracker -> `GraspController` -> coils and arm.

The controller is `whisker.sensing.grasp_control.GraspController`, the same object the simulator's rig
(whisker.sim.experiments.closed_loop) drives; only the two ends differ:

* frames come from a `whisker.vision.camera` source (PicameraSource on the Pi, VideoSource or FolderSource
  for a recording): the first `rest_frames` (coils off) set the tracker's rest baseline, then every
  frame is tracked and handed to the controller with its own time stamp;
* the controller's coil levels go through a `whisker.drive.actuation.Actuator` (rating check, thermal guard
  on the wall clock, watchdog, off on every exit) on a GpioBackend or Pca9685Backend; its vertical
  arm velocity goes to an `Arm`: `HandHeldArm` prints what the operator should do (the sensor is
  moved by hand), a robot driver implements the same two methods (no robot dependency here).

Fail safe. The controller aborts on a lost marker, dropped frames (a gap of more than
`max_gap_frames` periods between frame times) and contact before actuation; the rig adds: the
thermal guard cutting a coil the controller drives, a level refused by the ratings, no frame for
`watchdog_s` seconds of wall time (a stalled camera: a thread switches the coils off without
waiting for the next frame), the camera ending before the grasp did, and any error. Every abort
switches every coil off, stops the arm, logs the reason and gives a nonzero exit status
(`RigResult.exit_code`).

Log: one JSON line per controller frame (`FrameLog`): frame, t (s), phase, reason, levels (the
controller's), applied (after the guard), arm_mm_s, states, dx/dy (px), valid, tip force (mN) and
direction (deg, sensor frame) from whisker.sensing.contact_force, ms (tracking + controller). The lines go to
a hidden temporary file beside the log, renamed into place when the run ends (also after an abort
or Ctrl-C), so a reader never sees a half-written log under the final name.
"""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Protocol

import numpy as np

from whisker.sensing.states import STATE_NAMES

#: exit status of a run: the grasp ended (held and released, or missed and released); a fail-safe stop
EXIT_DONE, EXIT_ABORT = 0, 1


class Arm(Protocol):
    """What the rig asks of the arm (a UR driver implements these two, e.g. with speedl).

    ``command(velocity_mm_s, phase)``: vertical tool velocity from now on, mm/s, + up (the
    controller's Command.arm_mm_s), with the controller's phase for context; called once per frame.
    ``stop()``: stop moving now; must not raise (called on every abort and at the end).
    """

    def command(self, velocity_mm_s: float, phase: str) -> None: ...

    def stop(self) -> None: ...


PROMPTS = {"descend": "lower the sensor onto the object now",
           "close": "hold still: the whiskers close",
           "tighten": "hold still: the grip is adjusted",
           "lift": "lift the object now",
           "hold": "hold the object up and still",
           "done": "grasp over: the coils are off",
           "abort": "STOPPED: the coils are off"}


class HandHeldArm:
    """The operator moves the sensor: a prompt (to `echo`, default stderr) whenever the phase or the
    direction of the commanded velocity changes; the velocity itself is only reported."""

    def __init__(self, echo: Callable[[str], None] | None = None):
        self.echo = echo or (lambda s: print(s, file=sys.stderr, flush=True))
        self._last: tuple | None = None
        self.prompts: list[str] = []

    def command(self, velocity_mm_s: float, phase: str) -> None:
        key = (phase, int(np.sign(round(float(velocity_mm_s), 6))))
        if key == self._last:
            return
        self._last = key
        v = float(velocity_mm_s)
        move = f" ({'up' if v > 0 else 'down'} at {abs(v):.0f} mm/s)" if v else ""
        msg = f"[{phase}] {PROMPTS.get(phase, phase)}{move}"
        self.prompts.append(msg)
        self.echo(msg)

    def stop(self) -> None:
        pass


class FrameLog:
    """JSON lines written to a temporary file beside `path` and renamed into place by `close()`."""

    def __init__(self, path):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".tmp", dir=self.path.parent)
        self.tmp = Path(tmp)
        self._fh = os.fdopen(fd, "w")
        self.lines = 0

    def write(self, record: dict) -> None:
        self._fh.write(json.dumps(record, separators=(",", ":"), allow_nan=False) + "\n")
        self._fh.flush()      # a crash leaves every frame so far in the temporary file
        self.lines += 1

    def close(self) -> Path:
        if self._fh.closed:
            return self.path
        self._fh.flush()
        os.fsync(self._fh.fileno())
        self._fh.close()
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(self.tmp, 0o666 & ~umask)
        os.replace(self.tmp, self.path)
        return self.path


class FrameWatchdog:
    """Calls `on_timeout(seconds)` once when `kick()` has not been called for `timeout_s` (wall time)."""

    def __init__(self, timeout_s: float, on_timeout: Callable[[float], None], clock=time.monotonic):
        self.timeout_s, self.on_timeout, self.clock = float(timeout_s), on_timeout, clock
        self.fired: float | None = None
        self._last = clock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="whisker-frame-watchdog", daemon=True)
        self._thread.start()

    def kick(self) -> None:
        self._last = self.clock()

    def _run(self) -> None:
        step = min(0.01, self.timeout_s / 4)
        while not self._stop.wait(step):
            idle = self.clock() - self._last
            if idle > self.timeout_s:
                self.fired = idle
                try:
                    self.on_timeout(idle)
                finally:
                    return

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not threading.current_thread():
            self._thread.join(timeout=1.0)


@dataclass
class RigResult:
    phase: str                      # done / abort
    reason: str
    frames: int                     # frames handed to the controller
    exit_code: int
    events: list = field(default_factory=list)
    log_path: Path | None = None
    process_ms: list = field(default_factory=list)
    commands: list = field(default_factory=list)     # (t, phase, levels, arm_mm_s) per frame


def _r(v, nd=3):
    return None if not np.isfinite(v) else round(float(v), nd)


class HardwareRig:
    """One closed-loop grasp: `source` frames, `tracker` (whisker.vision.tracking.Tracker, not yet
    calibrated), `actuator` (whisker.drive.actuation.Actuator), `controller` (GraspController), `arm`
    (an `Arm`, default HandHeldArm). `log`: a FrameLog, a path, or None. `watchdog_s`: wall-clock
    seconds without a frame after which the coils go off (default: the controller's
    max_gap_frames periods, at least 0.2 s). `on_frame(rig, command, record)`: called after each
    frame's command was applied (tests read the pins there). `force_model`: a
    whisker.sensing.contact_force.ForceModel for the force columns (default: from the design)."""

    def __init__(self, design, source, tracker, actuator, controller, *, arm: Arm | None = None, log=None,
                 rest_frames: int = 5, max_frames: int | None = None, watchdog_s: float | None = None,
                 on_frame=None, force_model=None):
        from whisker.sensing.contact_force import ForceModel

        self.design, self.source, self.tracker = design, source, tracker
        self.actuator, self.controller = actuator, controller
        self.arm = arm if arm is not None else HandHeldArm()
        self.log = FrameLog(log) if isinstance(log, (str, Path)) else log
        self.rest_frames, self.max_frames = int(rest_frames), max_frames
        p = controller.p
        self.watchdog_s = watchdog_s if watchdog_s is not None else max(0.2, p.max_gap_frames / p.fps)
        self.on_frame = on_frame
        self.force_model = force_model if force_model is not None else ForceModel.from_design(design)
        self.n = design.whiskers.count
        self._stalled: float | None = None

    # -- the fail-safe stop -------------------------------------------------------------------
    def _off(self) -> None:
        self.actuator.off()
        try:
            self.arm.stop()
        except Exception:  # noqa: BLE001 - the coils are off; an arm driver's error must not hide that
            pass

    def _stall(self, idle_s: float) -> None:
        self._stalled = idle_s
        self._off()

    def run(self) -> RigResult:
        """Calibrate on the rest frames, then run the controller until done or abort (see the module doc)."""
        from whisker.sensing.contact_force import tip_force

        res = RigResult("abort", "", 0, EXIT_ABORT, log_path=self.log.path if self.log else None)
        frames = iter(self.source)
        dog = None
        try:
            self.actuator.neutral()
            rest = []
            for f in frames:
                rest.append(f)
                if len(rest) >= self.rest_frames:
                    break
            if len(rest) < self.rest_frames:
                res.reason = f"the camera gave {len(rest)} of the {self.rest_frames} rest frames"
                return res
            self.tracker.calibrate(rest)
            dog = FrameWatchdog(self.watchdog_s, self._stall)
            ctl = self.controller
            for f in frames:
                if self._stalled is not None:
                    res.reason = f"no camera frame for {self._stalled:.2f} s (> {self.watchdog_s:.2f} s)"
                    break
                dog.kick()
                t0 = time.perf_counter()
                tr = self.tracker.track(f.image)
                seen = len(ctl.log.events)
                cmd = ctl.step(f.time_s, tr.dx_px, tr.dy_px, tr.valid)
                ms = (time.perf_counter() - t0) * 1e3
                # this frame's events (phase changes, re-grips) say why, e.g. "8 whiskers hold"
                reason = "; ".join(e[2] for e in ctl.log.events[seen:] if e[2]) or cmd.reason
                phase = cmd.phase
                applied = self.actuator.apply(cmd.levels, cmd.phase)
                cut = (np.asarray(cmd.levels) != 0) & (applied == 0)
                g = self.actuator.guard
                if cut.any() and phase not in ("abort", "done"):
                    w = int(np.flatnonzero(cut)[0])
                    temp = f" at an estimated {g.temperatures[w]:.0f} C" if g is not None else ""
                    phase, reason = "abort", f"thermal guard cut coil {w}{temp}"
                    self._off()
                    applied = np.zeros(self.n)
                elif self._stalled is not None:       # the watchdog fired while this frame was processed
                    phase, reason = "abort", f"no camera frame for {self._stalled:.2f} s (> {self.watchdog_s:.2f} s)"
                    self._off()
                    applied = np.zeros(self.n)
                elif phase == "abort":
                    self._off()
                else:
                    self.arm.command(cmd.arm_mm_s, phase)
                force = tip_force(self.force_model, tr.dx_px, tr.dy_px, levels=applied,
                                  temperature_C=g.temperatures if g is not None else 20.0)
                rec = {"frame": int(f.index), "t": round(float(f.time_s), 4), "phase": phase, "reason": reason,
                       "levels": [round(float(x), 4) for x in cmd.levels],
                       "applied": [round(float(x), 4) for x in applied],
                       "arm_mm_s": round(float(cmd.arm_mm_s if phase != "abort" else 0.0), 3),
                       "states": [STATE_NAMES[int(s)] for s in ctl.est.labels],
                       "dx": [_r(v) for v in tr.dx_px], "dy": [_r(v) for v in tr.dy_px],
                       "valid": [bool(v) for v in tr.valid],
                       "force_mN": [_r(v, 2) for v in force.force_mN],
                       "direction_deg": [_r(v, 1) for v in force.direction_deg],
                       "ms": round(ms, 3)}
                if self.log is not None:
                    self.log.write(rec)
                res.frames += 1
                res.process_ms.append(ms)
                res.commands.append((float(f.time_s), phase, np.asarray(cmd.levels, float).copy(),
                                     float(cmd.arm_mm_s)))
                if self.on_frame is not None:
                    self.on_frame(self, cmd, rec)
                if phase in ("abort", "done"):
                    res.phase, res.reason = phase, reason or (ctl.log.events[-1][2] if ctl.log.events else "")
                    res.exit_code = EXIT_DONE if phase == "done" else EXIT_ABORT
                    break
                if self.max_frames is not None and res.frames >= self.max_frames:
                    res.reason = f"stopped after --max-frames {self.max_frames} frames, in phase {phase}"
                    break
            else:
                if self._stalled is not None:
                    res.reason = f"no camera frame for {self._stalled:.2f} s (> {self.watchdog_s:.2f} s)"
                else:
                    res.reason = (f"the camera stopped after {res.frames} frames, in phase {ctl.phase}"
                                  + (" (truncated video)" if getattr(self.source, "truncated", False) else ""))
            return res
        except BaseException as err:
            self._off()
            if isinstance(err, Exception):
                res.reason = f"error: {str(err).splitlines()[0] if str(err) else type(err).__name__}"
                return res
            res.reason = "interrupted (Ctrl-C)" if isinstance(err, KeyboardInterrupt) else f"stopped ({type(err).__name__})"
            raise
        finally:
            if dog is not None:
                dog.stop()
            self._off()
            res.events = list(getattr(getattr(self.controller, "log", None), "events", []))
            if res.phase == "abort" and res.reason and self.log is not None:
                self.log.write({"frame": None, "phase": "abort", "reason": res.reason})
            if self.log is not None:
                self.log.close()


def handheld_params(design, *, fps: float, descend_mm: float = 15.0, descend_s: float = 2.0, **kw):
    """ControlParams for a hand-held grasp: the design's grasp level (actuation.voltage, the paper's
    3 V, as a duty: whisker.drive.guard.volts_to_levels) and a notional descent of `descend_mm` in
    `descend_s` (the operator lowers the sensor meanwhile; the rest statistics are learned then)."""
    from whisker.sensing.grasp_control import ControlParams, settle_time_s
    from whisker.drive.guard import volts_to_levels

    if not (math.isfinite(descend_mm) and descend_mm > 0):
        raise ValueError(f"descent must be a positive distance in mm, got {descend_mm}")
    level = float(volts_to_levels(design, design.actuation.voltage))
    if "settle_s" not in kw:        # the whisker's own settling time (grasp_control.settle_time_s)
        kw["settle_s"] = settle_time_s(design, kw.get("model_tolerance", ControlParams.model_tolerance))
    return ControlParams(full_level=level, grasp_height_mm=0.0, start_height_mm=float(descend_mm), fps=float(fps),
                         descend_s=float(descend_s), **kw)
