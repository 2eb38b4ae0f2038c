"""Driving the coils safely: the pin map, H-bridge backends (gpiozero pins, the PCA9685 expander, mock
pins, simulated whiskers), the thermal and rating guard, the actuator with its configurations, and timed
coil sequences."""
