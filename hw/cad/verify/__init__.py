"""The geometry checks: verdicts, solid and mesh checks, the mold, wall thickness, the slicer check and the feasibility sweep."""
