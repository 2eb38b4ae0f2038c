"""`python -m whisker.ros [--ros-args -p source:=sim -p backend:=sim ...]`: the node with ROS-style
parameters (the way `ros2 run` and launch files pass them); `whisker ros --help` lists the same
settings as options. docs/ros2.md."""

from __future__ import annotations

import sys


def main(argv=None) -> int:
    try:
        from whisker.ros.node import spin
    except ModuleNotFoundError as err:
        from whisker.extras import missing_extra_message

        print(missing_extra_message(err, "python -m whisker.ros") or f"python -m whisker.ros: {err}", file=sys.stderr)
        return 1
    return spin(args=sys.argv if argv is None else argv)


if __name__ == "__main__":
    sys.exit(main())
