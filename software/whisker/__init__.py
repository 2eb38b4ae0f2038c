"""Whisker-array sensor: design model, CAD, calculators and sensor software."""

__version__ = "0.1.0"
