"""Commands that run, calibrate, record, simulate and check the sensor: `track`, `actuate`, `grasp`,
`record`, `recplot`, `states`, `live`, `closedloop`, `calibrate`, `classify`, `sim`, `doctor`, `ros` (the ROS 2
node, whisker.ros)."""
