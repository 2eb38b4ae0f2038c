"""CadQuery models of the sensor (importable as whisker.cad). Every part is a function of the design."""
