"""From tracks to what the sensor feels: per-whisker states, contact direction and tip force, the live
pipeline, and the closed-loop grasp controller and its hardware rig."""
