"""The ROS 2 node's parameters: name -> (default, description with units).

Kept apart from the node so that `whisker ros --help` and the docs can list them without rclpy.
"""

#: node parameters: name -> (default, description with units)
PARAMETERS = {
    "design_file": ("", "design TOML file ('' = the default design, hw/sensor.toml)"),
    "design_set": ([""], "design overrides SECTION.KEY=VALUE (as --set)"),
    "source": ("auto", "camera: auto (picamera on a Raspberry Pi, else sim), sim, picamera, a camera index, "
                       "a video file or an image folder"),
    "backend": ("auto", "coils: auto (gpio on a Raspberry Pi, else sim), sim, mock, gpio"),
    "tracker": ("roi", "marker tracking method: paper, contour, blob, roi, fit (docs/tracking.md)"),
    "method": ("adaptive", "state estimator: adaptive or authors (docs/states.md)"),
    "fps": (15.0, "frame rate of the sim camera, frames/s"),
    "rest_frames": (5, "first frames (whiskers untouched) that set the tracker's rest baseline"),
    "policy": ("derate", "thermal guard policy: derate or cut"),
    "prefix": ("whisker_", "prefix of the joint and frame names"),
    "levels": ([0.0], "coil levels, signed PWM duty per whisker, + = retract; setting it drives the coils"),
    "sequence": ("voltage_sweep", "coil sequence for ~/run_sequence: a TOML file or a shipped example name"),
    "grasp.config": ("all", "whiskers of the grasp: all, every-second, opposite or K"),
    "grasp.descend_mm": (5.0, "grasp: descent to the grasp height, mm (the rest is learned meanwhile)"),
    "grasp.descend_s": (0.5, "grasp: seconds of the descent"),
    "grasp.lift_mm": (0.0, "grasp: lift after the grip, mm (0: the robot lifts)"),
    "grasp.lift_s": (0.5, "grasp: seconds of the lift"),
    "grasp.hold_s": (0.0, "grasp: seconds of the hold, then release (0: hold until ~/release)"),
    "grasp.max_gap_frames": (2.5, "grasp: abort (coils off) when frames are further apart than this many periods"),
    "sim_contact.whiskers": ([0], "~/sim_contact: whiskers the simulated object touches"),
    "sim_contact.reach_deg": (6.0, "~/sim_contact: tilt the object pushes them to, deg (radially in)"),
    "sim_dt": (0.002, "backend sim: integration step, s (omega_n dt = 0.17 for the default design with the implicit "
                      "integrator; 0.0005, SimBackend's default, costs more than real time with the coils on)"),
    "save_frames": ("", "folder: write every camera frame (PNG) and times.csv (file, time_s: camera time s, "
                        "stamp_ns: the stamp of the frame's messages, ns)"),
    "diagnostics_period": (1.0, "seconds between /diagnostics messages"),
}
