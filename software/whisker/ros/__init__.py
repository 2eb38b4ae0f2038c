"""ROS 2 interface of the sensor (issue 32): the node `whisker ros` (whisker.ros.node) and the URDF
generated from the design (whisker.ros.urdf). docs/ros2.md."""
