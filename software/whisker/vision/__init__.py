"""Seeing the whiskers: frame sources, the camera and lens model, synthetic rendering, marker tracking,
deflection geometry, what a rest frame says about the camera, and tracks files."""
