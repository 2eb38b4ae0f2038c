"""Commands that make the hardware from the design: `design`, `cad`, `print`, `coil`, `hw`, `explore`."""
