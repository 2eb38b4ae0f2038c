"""What every geometry check returns, at the bottom of the CAD package: :class:`Check` (measured value,
limit, the design parameters that drive it), :func:`make_check` / :func:`measured_check` to make one,
and :func:`to_mesh`, the mesh the checks measure on. The modules that check parts (checks, walls, swing,
sequence, mold_checks) import these from here, so none of them needs another's internals.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import cadquery as cq
import numpy as np
import trimesh

# Intersection volumes below this are round-off, not contact (mm^3).
VOLUME_EPS = 1e-4

@dataclass
class Check:
    name: str
    part: str
    value: float
    limit: str
    unit: str
    ok: bool
    parameters: tuple[str, ...] = ()
    detail: str = ""
    # "conflict": a physical conflict of the design (parts collide, a wall is too thin, a part is too
    # big); "measurement": the built part is not what the design says (a fault of the CAD, not the design).
    kind: str = "conflict"

    def line(self) -> str:
        """One line for a refusal: what, measured value, limit, which parameters drive it."""
        val = f"{self.value:.4g}" if isinstance(self.value, float) else str(self.value)
        params = f" [parameters: {', '.join(self.parameters)}]" if self.parameters else ""
        det = f": {self.detail}" if self.detail else ""
        return f"{self.part}: {self.name} = {val} {self.unit}, needs {self.limit}{det}{params}".replace("  ", " ")

    def to_dict(self) -> dict:
        out = asdict(self)
        out["parameters"] = list(self.parameters)
        if isinstance(self.value, float) and not math.isfinite(self.value):
            out["value"] = None  # JSON has no NaN; the check has failed anyway
        return out


def make_check(name, part, value, ok, limit, unit="", parameters=(), detail="", kind="conflict") -> Check:
    if isinstance(value, (float, np.floating)):
        value = float(value)
        ok = bool(ok) and math.isfinite(value)
    return Check(name, part, value, limit, unit, bool(ok), tuple(parameters), detail, kind)


def measured_check(name, part, value, ok, limit, unit="", parameters=(), detail="") -> Check:
    """A check that the built part is what the design says (not a conflict of the design)."""
    return make_check(name, part, value, ok, limit, unit, parameters, detail, kind="measurement")


def to_mesh(shape: cq.Shape, tolerance: float, angular: float) -> trimesh.Trimesh:
    verts, tris = shape.tessellate(tolerance, angular)
    return trimesh.Trimesh(np.array([v.toTuple() for v in verts]), np.array(tris), process=True)
