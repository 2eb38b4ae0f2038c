"""Driver wiring generated from the design (imports as ``whisker.pcb``).

- :mod:`whisker.pcb.netlist`: the circuit in SKiDL (every part defined in code, no KiCad libraries),
  its ERC (errors counted, since SKiDL itself always exits 0) and its KiCad netlist;
- :mod:`whisker.pcb.pinout`: the pinout table (CSV, Markdown) from :func:`whisker.drive.pins.pin_map`;
- :mod:`whisker.pcb.diagram`: the wiring diagram (PNG, matplotlib);
- :mod:`whisker.pcb.build`: writes all of them into a folder (``make pcb`` -> hw/pcb/generated/).
"""
