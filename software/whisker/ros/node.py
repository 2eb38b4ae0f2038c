"""The ROS 2 node: camera -> tracker -> states -> contact force on topics, the coils behind services.

Topics (relative names, so a namespace or remapping applies; types and units in docs/ros2.md):

- ``joint_states`` (sensor_msgs/JointState): joint ``whisker_<i>`` per whisker, position = radial tilt
  of the whisker at its base, rad (+ = retraction, tip towards the centre: the URDF joint's sense),
  effort = the moment of the estimated tip force about that joint's axis, N m (whisker.sensing.contact_force).
- ``~/states`` (std_msgs/Int8MultiArray): per whisker 0 rest, 1 contact, 2 dynamic (whisker.sensing.states;
  airflow and other motion show as dynamic).
- ``~/whisker_<i>/wrench`` (geometry_msgs/WrenchStamped, frame ``whisker_<i>_base``: the pivot, x
  radially out): the estimated horizontal tip force, N, and its moment about the pivot, N m.
- ``~/whisker_<i>/contact`` (geometry_msgs/PointStamped, frame ``whisker_sensor``): the estimated
  contact point (the tip: contact_force assumes a tip contact), m; only while the whisker's state is contact.
- ``~/grasp_phase`` (std_msgs/String): the closed-loop grasp's phase and reason on every change.
- ``~/arm_velocity`` (geometry_msgs/TwistStamped, frame ``whisker_flange``): the grasp controller's
  vertical tool velocity, m/s (descend, lift), for a robot that lets the sensor lead.
- ``/diagnostics`` (diagnostic_msgs/DiagnosticArray, 1 Hz): frame rate, processing time, markers
  tracked; each coil's level and estimated temperature from the thermal guard.
- ``robot_description`` (std_msgs/String, transient local): the URDF (whisker.ros.urdf);
  ``/tf_static`` too when tf2_msgs is importable (a ROS 2 installation; the wheels have no tf2_msgs).

Coil commands (whisker.ros.coil_commands), every one through the same whisker.drive.actuation.Actuator
(ratings, thermal guard, watchdog, off on exit) as `whisker actuate`; a refusal answers with the same
one-line reason:

- parameter ``levels`` (double array, one signed PWM duty per whisker; set with the standard
  ``~/set_parameters`` service, e.g. ``ros2 param set /whisker levels "[0.5, 0, ...]"``);
- ``~/run_sequence`` (std_srvs/Trigger): the sequence named by parameter ``sequence``;
- ``~/grasp`` / ``~/release`` (std_srvs/Trigger): the closed-loop grasp (whisker.sensing.grasp_control) /
  coils off and any grasp or sequence ended;
- ``~/sim_contact`` (std_srvs/SetBool, simulator only): an object pushes whiskers
  ``sim_contact.whiskers`` by ``sim_contact.reach_deg`` (true) or leaves (false).
"""

from __future__ import annotations

import itertools
import math
import threading
import time
from pathlib import Path

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PointStamped, TwistStamped, WrenchStamped
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile
from sensor_msgs.msg import JointState
from std_msgs.msg import Int8MultiArray, MultiArrayDimension, String
from std_srvs.srv import SetBool, Trigger

from whisker.ros.coil_commands import CoilCommands
from whisker.ros.joints import joint_quantities, quaternion
from whisker.ros.parameters import PARAMETERS

def _on_pi() -> bool:
    try:
        return "raspberry pi" in Path("/proc/device-tree/model").read_text(errors="ignore").lower()
    except OSError:
        return False


class SensorNode(CoilCommands, Node):
    """See the module docstring. `design`: a whisker Design (None: from the design_file/design_set
    parameters). `overrides`: {parameter: value} (the `whisker ros` options)."""

    def __init__(self, design=None, overrides: dict | None = None, name: str = "whisker", **kw):
        ov = [Parameter(k, value=v) for k, v in (overrides or {}).items()]
        super().__init__(name, parameter_overrides=ov, **kw)
        for key, (default, text) in PARAMETERS.items():
            self.declare_parameter(key, default, ParameterDescriptor(description=text))
        self.design = design if design is not None else self._load_design()
        d, n = self.design, self.design.whiskers.count
        self.n = n
        self.prefix = self.p("prefix")
        self._lock = threading.RLock()
        self._stop = threading.Event()
        self.frames = 0
        self.tracked = 0
        self.latency_s: list[float] = []
        self.last_error: str | None = None
        self._build_pipeline()
        self._build_io()
        self.add_on_set_parameters_callback(self._on_set)
        self._thread = threading.Thread(target=self._run, name="whisker-frames", daemon=True)
        self._thread.start()

    # -- set-up ---------------------------------------------------------------------------------
    def p(self, key):
        return self.get_parameter(key).value

    def _load_design(self):
        from whisker.design import load_design

        sets = [s for s in self.p("design_set") if s]
        return load_design(self.p("design_file") or None, sets)

    def _build_pipeline(self) -> None:
        from whisker.drive.actuation import open_actuator
        from whisker.sensing.contact_force import ForceModel
        from whisker.vision.tracking import Tracker

        d = self.design
        source, backend = self.p("source"), self.p("backend")
        if backend == "auto":
            backend = "gpio" if _on_pi() else "sim"
        if source == "auto":
            source = "picamera" if _on_pi() else "sim"
        if source == "sim" and backend != "sim":
            raise ValueError("source sim needs backend sim (the simulated camera films the simulated whiskers)")
        self.source_name, self.backend_name = source, backend
        self.sim = None
        if backend == "sim":
            from whisker.ros.sim_contact import ContactBackend

            self.sim = ContactBackend(d, dt=float(self.p("sim_dt")))
        self.tracker = Tracker(d, self.p("tracker"))
        fps = float(self.p("fps"))
        if source == "sim":
            from whisker.data.recording import SimCamera

            self.src = SimCamera(d, self.sim, fps=fps)
        else:
            from whisker.vision.camera import open_source

            self.src = open_source(source, d)
        self.act = open_actuator(d, backend, policy=self.p("policy"), backend_object=self.sim)
        self.force_model = ForceModel.from_design(d)
        self.expected_px = None
        try:
            from whisker.sim.experiments.closed_loop import free_closing_px

            self.expected_px = free_closing_px(d)     # own-actuation displacement for the estimator
        except ImportError:
            pass
        self.grasp = None
        self.grasp_phase = ""
        self.sequence = None
        ang = np.radians(np.asarray(d.whisker_angles_deg, dtype=float))
        self.radial = np.stack([np.cos(ang), np.sin(ang)], axis=1)
        self.base_xyz_mm = np.stack([d.whiskers.ring_radius * self.radial[:, 0],
                                     d.whiskers.ring_radius * self.radial[:, 1], np.full(self.n, d.pivot_z)], 1)
        self.save_dir = Path(self.p("save_frames")) if self.p("save_frames") else None
        if self.save_dir is not None:
            self.save_dir.mkdir(parents=True, exist_ok=True)
            (self.save_dir / "times.csv").write_text("file,time_s,stamp_ns\n")

    def _build_io(self) -> None:
        from whisker.ros.urdf import joint_names, urdf

        pre, n = self.prefix, self.n
        self.joint_names = joint_names(self.design, pre)
        self.pub_joints = self.create_publisher(JointState, "joint_states", 10)
        self.pub_states = self.create_publisher(Int8MultiArray, "~/states", 10)
        self.pub_wrench = [self.create_publisher(WrenchStamped, f"~/whisker_{i}/wrench", 10) for i in range(n)]
        self.pub_contact = [self.create_publisher(PointStamped, f"~/whisker_{i}/contact", 10) for i in range(n)]
        self.pub_phase = self.create_publisher(String, "~/grasp_phase", 10)
        self.pub_arm = self.create_publisher(TwistStamped, "~/arm_velocity", 10)
        self.pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.urdf_text = urdf(self.design, prefix=pre)
        self.pub_description = self.create_publisher(String, "robot_description", latched)
        self.pub_description.publish(String(data=self.urdf_text))
        self.static_tf = self._publish_static_tf(latched)
        self.create_service(Trigger, "~/grasp", self._srv_grasp)
        self.create_service(Trigger, "~/release", self._srv_release)
        self.create_service(Trigger, "~/run_sequence", self._srv_sequence)
        self.create_service(SetBool, "~/sim_contact", self._srv_sim_contact)
        self.create_timer(0.02, self._tick_sequence)
        self.create_timer(float(self.p("diagnostics_period")), self._publish_diagnostics)
        self._diag_t, self._diag_frames = time.monotonic(), 0

    def _publish_static_tf(self, qos) -> bool:
        """The URDF's fixed frames on /tf_static, when tf2_msgs is there (a ROS 2 installation)."""
        try:
            from geometry_msgs.msg import TransformStamped
            from tf2_msgs.msg import TFMessage
        except ImportError:
            return False
        from urdf_parser_py.urdf import URDF      # ships with ROS 2 (urdfdom_py)

        robot = URDF.from_xml_string(self.urdf_text)
        out = TFMessage()
        now = self.get_clock().now().to_msg()
        for j in robot.joints:
            if j.type != "fixed":
                continue
            t = TransformStamped()
            t.header.stamp, t.header.frame_id, t.child_frame_id = now, j.parent, j.child
            t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = j.origin.xyz
            q = quaternion(*j.origin.rpy)
            t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z, t.transform.rotation.w = q
            out.transforms.append(t)
        self.create_publisher(TFMessage, "/tf_static", qos).publish(out)
        return True

    # -- the frame loop -------------------------------------------------------------------------
    def _run(self) -> None:
        from whisker.sensing.contact_force import tip_force
        from whisker.sensing.live import LivePipeline
        from whisker.sensing.states import make_estimator

        try:
            frames = iter(self.src)
            rest = list(itertools.islice(frames, int(self.p("rest_frames"))))
            if not rest:
                raise RuntimeError("no frames from the source for the rest baseline")
            stamps = [self.get_clock().now() for _ in rest]
            for f, s in zip(rest, stamps):
                self._save(f, s)
            self.tracker.calibrate(rest)
            pipe = LivePipeline(self.tracker, make_estimator(self.p("method"), self.n), force_model=None)
            for frame in frames:
                if self._stop.is_set():
                    break
                t0 = time.perf_counter()
                stamp = self.get_clock().now()
                with self._lock:
                    applied = np.asarray(self.act.applied, dtype=float).copy()
                live = pipe.step(frame, expected=self._expected(applied))
                temps = self.act.guard.temperatures if self.act.guard is not None else 20.0
                force = tip_force(self.force_model, live.dx_px, live.dy_px, levels=applied, temperature_C=temps)
                geo = self.tracker.deflection(live.result)
                self._grasp_step(frame, live)
                self._publish(stamp, live, force, geo)
                self.latency_s.append(time.perf_counter() - t0)
                self.frames += 1
                self._save(frame, stamp)
        except Exception as err:  # noqa: BLE001 - the node reports and keeps its services (coils off)
            if self._stop.is_set() or not self.context.ok():     # Ctrl-C / shutdown: not a fault
                self.act.off()
                return
            self.last_error = self._refusal(err)
            self.get_logger().error(f"frame loop stopped: {self.last_error}")
            self.act.off()

    def _save(self, frame, stamp) -> None:
        if self.save_dir is None:
            return
        import cv2

        name = f"frame_{frame.index:06d}.png"
        cv2.imwrite(str(self.save_dir / name), frame.image)
        with open(self.save_dir / "times.csv", "a") as fh:
            fh.write(f"{name},{frame.time_s:.6f},{stamp.nanoseconds}\n")

    def _expected(self, applied):
        """(n, 2) px each whisker's own coil moves it (free closing at its level), or None."""
        if self.expected_px is None or not np.any(applied):
            return None
        out = np.zeros((self.n, 2))
        for i, lv in enumerate(applied):
            if lv:
                out[i] = np.sign(lv) * np.asarray(self.expected_px(abs(lv)), dtype=float)[i]
        return out

    def _publish(self, stamp, live, force, geo) -> None:
        """One frame's messages (see the module docstring for the conventions)."""
        n, pre = self.n, self.prefix
        hdr_stamp = stamp.to_msg()
        radial_tilt, effort, f, lever, moment = joint_quantities(geo, force, self.radial)
        ok = np.asarray(live.valid, bool) & np.isfinite(radial_tilt)
        self.tracked = int(ok.sum())
        js = JointState()
        js.header.stamp = hdr_stamp
        js.name = list(self.joint_names)
        js.position = [float(v) if ok[i] else math.nan for i, v in enumerate(radial_tilt)]
        js.effort = [float(v) if ok[i] and math.isfinite(v) else math.nan for i, v in enumerate(effort)]
        self.pub_joints.publish(js)
        st = Int8MultiArray()
        st.layout.dim = [MultiArrayDimension(label="whisker: 0 rest, 1 contact, 2 dynamic", size=n, stride=n)]
        st.data = [int(s) for s in live.labels]
        self.pub_states.publish(st)
        for i in range(n):
            if not ok[i] or not np.all(np.isfinite(f[i])):
                continue
            c, s = self.radial[i]
            rot = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])         # sensor axes -> base axes
            fb, mb = rot @ f[i], rot @ moment[i]
            w = WrenchStamped()
            w.header.stamp, w.header.frame_id = hdr_stamp, f"{pre}{i}_base"
            w.wrench.force.x, w.wrench.force.y, w.wrench.force.z = map(float, fb)
            w.wrench.torque.x, w.wrench.torque.y, w.wrench.torque.z = map(float, mb)
            self.pub_wrench[i].publish(w)
            if int(live.labels[i]) == 1:
                pt = PointStamped()
                pt.header.stamp, pt.header.frame_id = hdr_stamp, f"{pre}sensor"
                pos = self.base_xyz_mm[i] * 1e-3 + lever[i]
                pt.point.x, pt.point.y, pt.point.z = map(float, pos)
                self.pub_contact[i].publish(pt)

    def _publish_diagnostics(self) -> None:
        now = time.monotonic()
        dt, df = now - self._diag_t, self.frames - self._diag_frames
        self._diag_t, self._diag_frames = now, self.frames
        arr = DiagnosticArray()
        arr.header.stamp = self.get_clock().now().to_msg()
        cam = DiagnosticStatus(name=f"{self.get_name()}: camera and tracking", hardware_id=self.source_name)
        lat = self.latency_s[-50:]
        cam.values = [KeyValue(key="frame rate (frames/s)", value=f"{df / dt:.2f}" if dt > 0 else "0"),
                      KeyValue(key="frames", value=str(self.frames)),
                      KeyValue(key="processing (ms/frame)", value=f"{1e3 * np.mean(lat):.2f}" if lat else "n/a"),
                      KeyValue(key="markers tracked", value=f"{self.tracked} of {self.n}")]
        if self.last_error:
            cam.level, cam.message = DiagnosticStatus.ERROR, self.last_error
        elif self.tracked < self.n:
            cam.level, cam.message = DiagnosticStatus.WARN, f"{self.n - self.tracked} markers lost"
        elif df == 0:
            cam.level, cam.message = DiagnosticStatus.WARN, "no frames"
        else:
            cam.level, cam.message = DiagnosticStatus.OK, "tracking"
        coils = DiagnosticStatus(name=f"{self.get_name()}: coils", hardware_id=self.backend_name)
        g = self.act.guard
        vals = [KeyValue(key="phase", value=str(self.act.phase))]
        for i in range(self.n):
            vals.append(KeyValue(key=f"coil {i} level", value=f"{float(self.act.applied[i]):.3f}"))
            if g is not None:
                vals.append(KeyValue(key=f"coil {i} temperature (C)", value=f"{float(g.temperatures[i]):.1f}"))
        if g is not None:
            vals.append(KeyValue(key="cut-off (C)", value=f"{g.cut_C:.1f}"))
            vals.append(KeyValue(key="guard trips", value=str([int(x) for x in g.trips])))
        coils.values = vals
        tripped = g is not None and bool(np.any(g.tripped))
        coils.level = DiagnosticStatus.ERROR if tripped else DiagnosticStatus.OK
        coils.message = "thermal guard cut a coil" if tripped else (self.grasp_phase or "ready")
        arr.status = [cam, coils]
        self.pub_diag.publish(arr)

    # -- shutdown -------------------------------------------------------------------------------
    def close(self) -> None:
        """Stop the frame loop and switch every coil off (also on Ctrl-C / SIGTERM through main)."""
        self._stop.set()
        try:
            self.src.close()
        finally:
            self._thread.join(timeout=2.0)
            self.act.close()


def spin(design=None, overrides: dict | None = None, args=None, duration_s: float | None = None,
         on_ready=None) -> int:
    """Init ROS, run the node until Ctrl-C / SIGTERM (or `duration_s`), coils off at the end."""
    from whisker.drive.actuation import deenergise_on_signals

    rclpy.init(args=args)
    node = None
    try:
        with deenergise_on_signals():
            node = SensorNode(design, overrides)
            node.get_logger().info(f"whisker: source {node.source_name}, backend {node.backend_name}, "
                                   f"{node.n} whiskers; joint_states, ~/states, services ~/grasp ~/release "
                                   f"~/run_sequence, parameter levels")
            if on_ready is not None:
                on_ready(node)
            end = math.inf if duration_s is None else time.monotonic() + duration_s
            while rclpy.ok() and time.monotonic() < end:
                rclpy.spin_once(node, timeout_sec=0.05)
    except KeyboardInterrupt:
        pass
    finally:
        if node is not None:
            node.close()
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return 0
