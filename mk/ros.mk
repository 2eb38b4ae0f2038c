# ROS 2 node (issue 32). See docs/ros2.md.
#   make ros                 the node on the simulator's camera and coils (Ctrl-C stops it, coils off)
#   make ros-urdf            the sensor's URDF and the frames picture from the design
#   make bench-ros           frame -> published message latency -> benchmarks/results/ros.md (+ states.md block)
ROS_OUT ?= $(OUT)/ros

.PHONY: ros ros-urdf bench-ros

ros: $(BIN)/.installed ## run the ROS 2 node on the simulator (whisker ros --source sim --backend sim)
	$(BIN)/whisker ros --source sim --backend sim $(DESIGN_ARGS)

ros-urdf: $(BIN)/.installed ## the sensor's URDF and frames picture -> exports/ros/ (docs/images/ros_frames.png)
	$(BIN)/whisker ros $(DESIGN_ARGS) --urdf $(ROS_OUT)/whisker_array.urdf --frames-png docs/images/ros_frames.png

bench-ros: $(BIN)/.installed ## ROS 2 node latency, frame -> message -> benchmarks/results/ros.md
	$(BIN)/python benchmarks/bench_ros.py
