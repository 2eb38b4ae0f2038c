"""The sensor assembly: mount, membrane and, per whisker, rod, bobbin, winding, its two leads and
magnet, all in place."""

from __future__ import annotations

import cadquery as cq

from whisker.design import Design

from whisker.cad.solids import reference

from whisker.cad.assembly import swing


def sensor_assembly(d: Design, mount: cq.Shape, membrane: cq.Shape, tilt_deg: float = 0.0) -> cq.Assembly:
    """Every part where it sits in the finished sensor (whiskers tilted by tilt_deg, retraction +)."""
    assy = cq.Assembly(name="whisker_sensor")
    assy.add(mount, name="mount", color=cq.Color(0.55, 0.45, 0.85))
    assy.add(membrane, name="membrane", color=cq.Color(0.6, 0.6, 0.65))
    for i, a in enumerate(d.whisker_angles_deg):
        assy.add(reference.rod(d, a, tilt_deg), name=f"rod_{i}", color=cq.Color(0.1, 0.1, 0.1))
        assy.add(reference.bobbin(d, a, tilt_deg), name=f"bobbin_{i}", color=cq.Color(0.2, 0.2, 0.25))
        assy.add(reference.winding(d, a, tilt_deg), name=f"winding_{i}", color=cq.Color(0.72, 0.45, 0.2))
        for s in (-1, 1):
            assy.add(swing.lead_solid(d, i, s, tilt_deg), name=f"lead_{i}{'p' if s > 0 else 'm'}",
                     color=cq.Color(0.8, 0.1, 0.1))
        assy.add(reference.magnet(d, a), name=f"magnet_{i}", color=cq.Color(0.75, 0.75, 0.78))
    return assy


def export_step(assy: cq.Assembly, path: str) -> None:
    from cadquery.occ_impl.exporters.assembly import exportAssembly

    if not exportAssembly(assy, path):
        raise RuntimeError(f"STEP export of the assembly failed: {path}")
