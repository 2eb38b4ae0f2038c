"""The solids: one module per part, each a function of the design (cq_warehouse style), and the primitives they share."""
