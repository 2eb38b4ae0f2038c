"""ROS 2 interface of the sensor (issue 32): the node `whisker ros` (whisker.ros.node, its coil commands in
whisker.ros.coil_commands) and the URDF generated from the design (whisker.ros.urdf). docs/ros2.md."""
