"""Example actuation sequences, shipped as the data package ``whisker.sequences``
(``whisker actuate sequence voltage_sweep`` finds them by name)."""
