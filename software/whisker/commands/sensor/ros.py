"""`whisker ros`: the ROS 2 node (whisker.ros.node): tracks, states, contacts and coil services."""

from __future__ import annotations

import click

from whisker.cliutil import design_options, fail


@click.command(context_settings={"ignore_unknown_options": True})
@design_options
@click.option("--source", default="auto", show_default=True, metavar="SOURCE",
              help="Camera: auto (picamera on a Raspberry Pi, else sim), sim (the simulator), picamera, a camera "
                   "index, a video file or an image folder.")
@click.option("--backend", type=click.Choice(["auto", "sim", "mock", "gpio"]), default="auto", show_default=True,
              help="Coils: auto (gpio on a Raspberry Pi, else sim), sim (the simulator), mock (gpiozero mock pins), gpio.")
@click.option("--tracker", type=click.Choice(["paper", "contour", "blob", "roi", "fit"]), default="roi",
              show_default=True, help="Marker tracking method (docs/tracking.md).")
@click.option("--method", type=click.Choice(["authors", "adaptive"]), default="adaptive", show_default=True,
              help="State estimator (docs/states.md).")
@click.option("--fps", type=click.FloatRange(1, 240), default=15.0, show_default=True,
              help="Frame rate of --source sim, frames/s.")
@click.option("--policy", type=click.Choice(["derate", "cut"]), default="derate", show_default=True,
              help="Thermal guard: derate near the limit, or full level then off.")
@click.option("--duration", type=click.FloatRange(0, None, min_open=True), default=None,
              help="Stop after this many seconds (default: until Ctrl-C or SIGTERM).")
@click.option("--urdf", "urdf_out", type=click.Path(dir_okay=False, allow_dash=True), default=None,
              help="Write the sensor's URDF (metres, radians; from the design) to FILE ('-': stdout) and exit, "
                   "without ROS: for a robot description to include.")
@click.option("--frames-png", type=click.Path(dir_okay=False), default=None,
              help="Draw the URDF's frames (side and top view, mm) into a PNG and exit, without ROS.")
@click.option("--prefix", default="whisker_", show_default=True,
              help="Prefix of the joint and frame names (two sensors on one robot: left_, right_).")
@click.argument("ros_args", nargs=-1, type=click.UNPROCESSED)
def cli(design, source, backend, tracker, method, fps, policy, duration, urdf_out, frames_png, prefix, ros_args):
    """Run the ROS 2 node: the live pipeline on topics, the coils behind services (docs/ros2.md).

    Publishes joint_states (sensor_msgs/JointState: whisker_<i>, radial tilt rad, base moment N m),
    ~/states, ~/whisker_<i>/wrench (N, N m) and ~/whisker_<i>/contact (m), /diagnostics (frame rate,
    coil temperatures C) and robot_description (the URDF from the design). Services: ~/grasp,
    ~/release, ~/run_sequence (std_srvs/Trigger), parameter `levels` (PWM duty per whisker) through
    the same ratings and thermal guard as `whisker actuate`. Anything after --ros-args goes to ROS
    (e.g. --ros-args -r __ns:=/left -p grasp.config:=opposite). Stop with Ctrl-C: the coils go off.

    \b
      whisker ros --source sim --backend sim
      whisker ros --source picamera --backend gpio --ros-args -r __node:=whisker_left
    """
    import re
    import sys

    if ros_args and ros_args[0] != "--ros-args":
        fail(f"ros: unexpected argument {ros_args[0]!r} (ROS arguments go after --ros-args)")
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", prefix):
        fail(f"ros: --prefix {prefix!r} must be a ROS name part: a letter, then letters, digits or _")
    if urdf_out or frames_png:
        from whisker.files import atomic_write_bytes, atomic_write_text
        from whisker.ros.urdf import urdf

        text = urdf(design, prefix=prefix)
        if urdf_out == "-":
            click.echo(text, nl=False)
        elif urdf_out:
            atomic_write_text(urdf_out, text)
        if frames_png:
            import tempfile
            from pathlib import Path

            from whisker.ros.frames_plot import draw_frames

            with tempfile.TemporaryDirectory() as tmp:
                draw_frames(text, Path(tmp) / "frames.png")
                atomic_write_bytes(frames_png, (Path(tmp) / "frames.png").read_bytes())
        return
    from whisker.ros.node import spin

    overrides = {"source": source, "backend": backend, "tracker": tracker, "method": method, "fps": float(fps),
                 "policy": policy, "prefix": prefix}
    try:
        spin(design, overrides, args=[sys.argv[0], *ros_args], duration_s=duration)
    except (ValueError, RuntimeError, OSError) as err:
        fail(f"ros: {str(err).splitlines()[0] if str(err) else type(err).__name__}",
             code=1 if isinstance(err, (RuntimeError, OSError)) else 2)
