"""Mechanics of the sensor's parts from geometry and material data (layer: above design, below coil).

- :mod:`whisker.mechanics.membrane` -- the cast membrane's rotational stiffness per whisker and the
  coupling between whiskers, from a finite-element model (scikit-fem), cached per geometry.
- :mod:`whisker.mechanics.materials` -- the silicone's data file (hw/materials/).
- :mod:`whisker.mechanics.plate` -- the closed-form limiting case (Kirchhoff plate with a rigid hub).
"""
