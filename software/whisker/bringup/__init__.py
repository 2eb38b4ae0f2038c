"""The calibrations a builder runs on the assembled sensor: the lens (ChArUco), the coil wiring
self-test, and the membrane stiffness measured on the device."""
