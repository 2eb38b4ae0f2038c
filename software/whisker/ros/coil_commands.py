"""The ROS 2 node's coil commands, mixed into `whisker.ros.node.SensorNode`: every one goes through
the node's one whisker.drive.actuation.Actuator (ratings, thermal guard, watchdog, off on exit), as
`whisker actuate` does, and a refusal answers with the same one-line reason.

- parameter ``levels`` (one signed PWM duty per whisker, through ``~/set_parameters``);
- ``~/run_sequence`` (std_srvs/Trigger): the sequence named by parameter ``sequence``, ticked every 20 ms;
- ``~/grasp`` / ``~/release`` (std_srvs/Trigger): the closed-loop grasp (whisker.sensing.grasp_control),
  stepped on every tracked frame, its phase on ``~/grasp_phase`` and its arm velocity (m/s) on
  ``~/arm_velocity`` / coils off and any grasp or sequence ended;
- ``~/sim_contact`` (std_srvs/SetBool, simulator only): an object pushes whiskers ``sim_contact.whiskers``
  by ``sim_contact.reach_deg`` (true) or leaves (false).
"""

from __future__ import annotations

import math
import time

import numpy as np
from geometry_msgs.msg import TwistStamped
from rcl_interfaces.msg import SetParametersResult
from std_msgs.msg import String


class CoilCommands:
    """The coil-command half of `SensorNode` (an rclpy Node). It uses the node's design, n, prefix,
    p(key) (a parameter's value), act (the Actuator), _lock, sim (the simulator backend or None),
    expected_px (the free-closing model or None) and the publishers pub_phase and pub_arm; it keeps
    the running grasp (grasp, grasp_t0, grasp_phase) and sequence (sequence)."""

    def _refusal(self, err: Exception) -> str:
        return str(err).splitlines()[0] if str(err) else type(err).__name__

    def _on_set(self, params) -> SetParametersResult:
        from whisker.drive.guard import RatingError

        for prm in params:
            if prm.name == "levels":
                try:
                    lv = np.asarray(prm.value, dtype=float)
                    with self._lock:
                        self._end_activity("levels set")
                        self.act.apply(lv, "levels")
                except (RatingError, ValueError, RuntimeError, TypeError) as err:
                    return SetParametersResult(successful=False, reason=self._refusal(err))
            elif prm.name in ("source", "backend", "tracker", "method", "fps", "rest_frames", "policy", "prefix",
                              "design_file", "design_set", "save_frames", "diagnostics_period", "sim_dt"):
                return SetParametersResult(successful=False, reason=f"{prm.name} is read at start only: restart the node")
        return SetParametersResult(successful=True)

    def _end_activity(self, why: str) -> None:
        """End a running grasp or sequence (caller holds the lock)."""
        if self.grasp is not None:
            self._set_phase("done", why)
            self.grasp = None
        self.sequence = None

    def _set_phase(self, phase: str, reason: str) -> None:
        text = f"{phase}: {reason}" if reason else phase
        if text != self.grasp_phase:
            self.grasp_phase = text
            self.pub_phase.publish(String(data=text))

    def _srv_release(self, request, response):
        with self._lock:
            self._end_activity("released by ~/release")
            self.act.neutral()
        response.success, response.message = True, "coils off"
        return response

    def _srv_sequence(self, request, response):
        from whisker.drive.sequences import SequenceRunner, load_sequence

        try:
            steps = load_sequence(self.design, self.p("sequence"))
            with self._lock:
                self._end_activity("a sequence started")
                runner = SequenceRunner(self.act, steps)
                runner.start(time.monotonic())
                self.sequence = runner
        except (ValueError, OSError, RuntimeError) as err:
            response.success, response.message = False, self._refusal(err)
            return response
        response.success = True
        response.message = f"sequence {self.p('sequence')}: {len(steps)} steps, {runner.total_s:.2f} s"
        return response

    def _tick_sequence(self) -> None:
        with self._lock:
            if self.sequence is None:
                return
            try:
                self.sequence.tick(time.monotonic())
                done = self.sequence.done
            except Exception as err:  # noqa: BLE001 - a refused step or a guard failure: off, say why
                self.get_logger().error(f"sequence stopped: {self._refusal(err)}")
                done = True
            if done:
                self.sequence = None
                self.act.neutral()

    def _srv_grasp(self, request, response):
        from whisker.drive.actuation import configuration
        from whisker.sensing.grasp_control import GraspController
        from whisker.drive.guard import RatingError, ThermalGuard
        from whisker.sensing.rig import handheld_params

        try:
            if self.expected_px is None:
                raise RuntimeError("the grasp needs the free-closing model (whisker.sim.experiments.closed_loop)")
            active = list(map(int, np.flatnonzero(configuration(self.n, self.p("grasp.config")))))
            hold = float(self.p("grasp.hold_s"))
            params = handheld_params(self.design, fps=float(self.p("fps")), descend_mm=float(self.p("grasp.descend_mm")),
                                     descend_s=float(self.p("grasp.descend_s")), lift_mm=float(self.p("grasp.lift_mm")),
                                     lift_s=float(self.p("grasp.lift_s")), hold_s=hold if hold > 0 else math.inf,
                                     max_gap_frames=float(self.p("grasp.max_gap_frames")))
            from whisker.drive.guard import check_levels

            check_levels(self.design, np.where(np.isin(np.arange(self.n), active), params.full_level, 0.0))
            ctl = GraspController(self.n, active, params, self.expected_px, guard=ThermalGuard(self.design, clock=lambda: 0.0))
        except (RatingError, ValueError, RuntimeError) as err:
            response.success, response.message = False, self._refusal(err)
            return response
        with self._lock:
            self._end_activity("a new grasp started")
            self.grasp = ctl
            self.grasp_t0 = None
        response.success = True
        response.message = (f"grasp started on whiskers {active} at level {params.full_level:.3f}: "
                            f"descend {params.descend_s:g} s, then close")
        return response

    def _srv_sim_contact(self, request, response):
        if self.sim is None:
            response.success, response.message = False, "sim_contact needs backend sim"
            return response
        try:
            who = [int(i) for i in self.p("sim_contact.whiskers")] if request.data else []
            bad = [i for i in who if not 0 <= i < self.n]
            if bad:
                raise ValueError(f"sim_contact.whiskers: whisker {bad[0]} is not in 0..{self.n - 1}")
            self.sim.set_contact(who, float(self.p("sim_contact.reach_deg")))
        except ValueError as err:
            response.success, response.message = False, self._refusal(err)
            return response
        response.success = True
        response.message = f"object on whiskers {who}" if who else "object removed"
        return response

    def _grasp_step(self, frame, live) -> None:
        from whisker.drive.guard import RatingError

        with self._lock:
            ctl = self.grasp
            if ctl is None:
                return
            if self.grasp_t0 is None:
                self.grasp_t0 = frame.time_s
            cmd = ctl.step(frame.time_s - self.grasp_t0, live.dx_px, live.dy_px, live.valid)
            reason = ctl.log.events[-1][2] if ctl.log.events else cmd.reason
            try:
                self.act.apply(cmd.levels, cmd.phase)
            except (RatingError, ValueError, RuntimeError) as err:
                self.grasp = None
                self.act.off()
                self._set_phase("abort", self._refusal(err))
                return
            self._set_phase(cmd.phase, reason)
            arm = TwistStamped()
            arm.header.frame_id = f"{self.prefix}flange"
            arm.header.stamp = self.get_clock().now().to_msg()
            arm.twist.linear.z = float(cmd.arm_mm_s) * 1e-3
            self.pub_arm.publish(arm)
            if cmd.phase in ("done", "abort"):
                self.grasp = None
                self.act.neutral()
