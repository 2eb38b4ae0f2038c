"""KiCad's pcbnew, driven from a JSON job: run ONLY with the system python3 that has KiCad's module.

``/usr/bin/python3 kicad_job.py JOB.json``; whisker.pcb.kicad runs it in a subprocess because pcbnew is
a module of Debian's python3-kicad (KiCad 9), not installable into the project's virtualenv. This file
imports nothing from whisker. Jobs (``"op"``):

- ``build``: a board from a placement spec (outline, holes, footprints from KiCad's libraries with
  their pad nets, scripted tracks/vias, zones, design rules), saved as .kicad_pcb, plus its Specctra
  DSN for the router;
- ``import_ses``: a routed Specctra session into the board, zones filled, saved;
- ``copper``: the copper geometry of a board (pads, tracks, vias, filled zones as polygons, per
  layer) as JSON, for the copper-connectivity check (whisker.pcb.copper);
- ``fill``: refill the zones of a board and save it.
"""

from __future__ import annotations

import json
import math
import os
import sys

import pcbnew

MM = pcbnew.FromMM
COPPER = (("F.Cu", pcbnew.F_Cu), ("In1.Cu", pcbnew.In1_Cu), ("In2.Cu", pcbnew.In2_Cu), ("B.Cu", pcbnew.B_Cu))
FOOTPRINTS = os.environ.get("KICAD9_FOOTPRINT_DIR", "/usr/share/kicad/footprints")


def _v(x, y):
    return pcbnew.VECTOR2I(MM(float(x)), MM(float(y)))


def _outline(board, w, h, r, width=0.1):
    """Rounded-rectangle Edge.Cuts: four lines and four quarter arcs."""
    def line(a, b):
        s = pcbnew.PCB_SHAPE(board, pcbnew.SHAPE_T_SEGMENT)
        s.SetStart(_v(*a))
        s.SetEnd(_v(*b))
        s.SetLayer(pcbnew.Edge_Cuts)
        s.SetWidth(MM(width))
        board.Add(s)

    def arc(c, start, mid, end):
        s = pcbnew.PCB_SHAPE(board, pcbnew.SHAPE_T_ARC)
        s.SetArcGeometry(_v(*start), _v(*mid), _v(*end))
        s.SetLayer(pcbnew.Edge_Cuts)
        s.SetWidth(MM(width))
        board.Add(s)

    k = r * (1 - math.sqrt(0.5))
    line((r, 0), (w - r, 0))
    line((w, r), (w, h - r))
    line((w - r, h), (r, h))
    line((0, h - r), (0, r))
    arc((w - r, r), (w - r, 0), (w - k, k), (w, r))
    arc((w - r, h - r), (w, h - r), (w - k, h - k), (w - r, h))
    arc((r, h - r), (r, h), (k, h - k), (0, h - r))
    arc((r, r), (0, r), (k, k), (r, 0))


def _net(board, nets, name):
    if not name:
        return None
    if name not in nets:
        ni = pcbnew.NETINFO_ITEM(board, name)
        board.Add(ni)
        nets[name] = ni
    return nets[name]


def _layer(name):
    return {"F.Cu": pcbnew.F_Cu, "B.Cu": pcbnew.B_Cu, "In1.Cu": pcbnew.In1_Cu, "In2.Cu": pcbnew.In2_Cu}[name]


def _rules(board, rules):
    ds = board.GetDesignSettings()
    ds.SetCopperLayerCount(int(rules.get("layers", 2)))
    ds.m_MinClearance = MM(rules["clearance"])
    ds.m_TrackMinWidth = MM(rules["min_track"])
    ds.m_ViasMinSize = MM(rules["via_diameter"])
    ds.m_MinThroughDrill = MM(rules.get("min_drill", 0.2))
    ds.m_CopperEdgeClearance = MM(rules["edge_clearance"])
    ds.m_HoleClearance = MM(rules["hole_clearance"])
    ns = ds.m_NetSettings
    default = ns.GetDefaultNetclass()
    default.SetClearance(MM(rules["clearance"]))
    default.SetTrackWidth(MM(rules["track_width"]))
    default.SetViaDiameter(MM(rules["via_diameter"]))
    default.SetViaDrill(MM(rules["via_drill"]))


def _footprint(board, nets, p):
    lib, name = p["footprint"].split(":", 1)
    fp = pcbnew.FootprintLoad(os.path.join(FOOTPRINTS, lib + ".pretty"), name)
    if fp is None:
        raise SystemExit(f"footprint {p['footprint']} not found under {FOOTPRINTS}")
    fp.SetFPID(pcbnew.LIB_ID(lib, name))
    fp.SetReference(p["ref"])
    fp.SetValue(p["value"])
    board.Add(fp)
    fp.SetPosition(_v(p["x"], p["y"]))
    if p.get("side") == "bottom":
        fp.Flip(fp.GetPosition(), pcbnew.FLIP_DIRECTION_LEFT_RIGHT)
    fp.SetOrientationDegrees(float(p.get("rot", 0.0)))
    for key, val in p.get("fields", {}).items():
        fp.SetField(key, val)
        fld = fp.GetFieldByName(key)
        if fld is not None:
            fld.SetVisible(False)
    fp.Reference().SetVisible(bool(p.get("show_ref", True)))
    fp.Value().SetVisible(False)
    pads = p.get("pads", {})
    for pad in fp.Pads():
        net = pads.get(pad.GetNumber())
        if net:
            pad.SetNet(_net(board, nets, net))
    if p.get("dnp"):
        fp.SetDNP(True)
    if p.get("exclude_from_pos"):
        fp.SetExcludedFromPosFiles(True)
    if p.get("exclude_from_bom"):
        fp.SetExcludedFromBOM(True)
    return fp


def _zone(board, nets, z):
    zone = pcbnew.ZONE(board)
    layers = pcbnew.LSET()
    layers.AddLayer(_layer(z["layer"]))
    zone.SetLayerSet(layers)  # ZONE.SetLayer() leaves an inner-layer zone on F.Cu in KiCad 9
    zone.SetNet(_net(board, nets, z["net"]))
    zone.SetAssignedPriority(int(z.get("priority", 0)))
    zone.SetLocalClearance(MM(z["clearance"]))
    zone.SetMinThickness(MM(z.get("min_width", 0.25)))
    zone.SetThermalReliefGap(MM(z.get("thermal_gap", 0.3)))
    zone.SetThermalReliefSpokeWidth(MM(z.get("spoke_width", 0.4)))
    zone.SetPadConnection(pcbnew.ZONE_CONNECTION_FULL)  # planes: solid joins, no starved thermals
    zone.SetIslandRemovalMode(pcbnew.ISLAND_REMOVAL_MODE_ALWAYS)
    outline = zone.Outline()
    outline.NewOutline()
    for x, y in z["polygon"]:
        outline.Append(MM(x), MM(y))
    board.Add(zone)


def build(job):
    spec = json.load(open(job["spec"]))
    board = pcbnew.BOARD()
    nets = {}
    board.SetCopperLayerCount(int(spec["board"].get("layers", 2)))
    _rules(board, {**spec["rules"], "layers": spec["board"].get("layers", 2)})
    for lid in (pcbnew.In1_Cu, pcbnew.In2_Cu):
        if board.GetCopperLayerCount() >= 4:
            board.SetLayerType(lid, pcbnew.LT_POWER)
    b = spec["board"]
    _outline(board, b["width"], b["height"], b["corner_radius"])
    for p in spec["parts"]:
        _footprint(board, nets, p)
    for t in spec.get("tracks", []):
        tr = pcbnew.PCB_TRACK(board)
        tr.SetStart(_v(*t["start"]))
        tr.SetEnd(_v(*t["end"]))
        tr.SetWidth(MM(t["width"]))
        tr.SetLayer(_layer(t["layer"]))
        tr.SetNet(_net(board, nets, t["net"]))
        tr.SetLocked(True)
        board.Add(tr)
    for v in spec.get("vias", []):
        via = pcbnew.PCB_VIA(board)
        via.SetPosition(_v(*v["at"]))
        via.SetWidth(MM(v["diameter"]))
        via.SetDrill(MM(v["drill"]))
        via.SetNet(_net(board, nets, v["net"]))
        via.SetLocked(True)
        board.Add(via)
    for z in spec.get("zones", []):
        _zone(board, nets, z)
    for t in spec.get("texts", []):
        tx = pcbnew.PCB_TEXT(board)
        tx.SetText(t["text"])
        tx.SetPosition(_v(t["x"], t["y"]))
        tx.SetLayer(pcbnew.F_SilkS if t.get("layer", "F.SilkS") == "F.SilkS" else pcbnew.B_SilkS)
        tx.SetTextSize(pcbnew.VECTOR2I(MM(t.get("size", 1.0)), MM(t.get("size", 1.0))))
        tx.SetTextThickness(MM(t.get("size", 1.0) * 0.15))
        if t.get("layer") == "B.SilkS":
            tx.SetMirrored(True)
        board.Add(tx)
    board.BuildConnectivity()
    pads = []
    for fp in board.GetFootprints():
        fc = fp.GetPosition()
        for pad in fp.Pads():
            bb = pad.GetBoundingBox()
            c = pad.GetPosition()
            pads.append({"ref": fp.GetReference(), "pad": pad.GetNumber(), "net": pad.GetNetname(),
                         "at": [pcbnew.ToMM(c.x), pcbnew.ToMM(c.y)], "fp_at": [pcbnew.ToMM(fc.x), pcbnew.ToMM(fc.y)],
                         "bbox": [pcbnew.ToMM(bb.GetLeft()), pcbnew.ToMM(bb.GetTop()), pcbnew.ToMM(bb.GetRight()),
                                  pcbnew.ToMM(bb.GetBottom())],
                         "through": pad.GetDrillSize().x > 0, "bottom": fp.IsFlipped()})
    pcbnew.SaveBoard(job["board"], board)
    if job.get("dsn"):
        if not pcbnew.ExportSpecctraDSN(board, job["dsn"]):
            raise SystemExit("Specctra DSN export failed")
    json.dump({"pads": pads}, open(job["result"], "w"))


def fill(board):
    filler = pcbnew.ZONE_FILLER(board)
    filler.Fill(board.Zones())


def import_ses(job):
    board = pcbnew.LoadBoard(job["board"])
    if not pcbnew.ImportSpecctraSES(board, job["ses"]):
        raise SystemExit("Specctra SES import failed")
    fill(board)
    pcbnew.SaveBoard(job["out"], board)


def refill(job):
    board = pcbnew.LoadBoard(job["board"])
    fill(board)
    pcbnew.SaveBoard(job["out"], board)


def _poly_points(shape_poly_set):
    """Outlines (holes dropped: they only remove copper inside one item) as [[x, y], ...] lists, mm."""
    out = []
    for i in range(shape_poly_set.OutlineCount()):
        ol = shape_poly_set.Outline(i)
        out.append([[pcbnew.ToMM(ol.CPoint(k).x), pcbnew.ToMM(ol.CPoint(k).y)] for k in range(ol.PointCount())])
    return out


def copper(job):
    """Copper items per layer with their polygons: what conducts, independent of the net labels."""
    board = pcbnew.LoadBoard(job["board"])
    items = []
    for fp in board.GetFootprints():
        for pad in fp.Pads():
            layers = [(n, lid) for n, lid in COPPER if pad.IsOnLayer(lid)]
            for name, lid in layers:
                poly = pcbnew.SHAPE_POLY_SET()
                pad.TransformShapeToPolygon(poly, lid, 0, MM(0.001), pcbnew.ERROR_INSIDE)
                items.append({"kind": "pad", "id": f"{fp.GetReference()}:{pad.GetNumber()}", "layer": name,
                              "polys": _poly_points(poly), "through": pad.GetDrillSize().x > 0,
                              "net": pad.GetNetname(), "at": [pcbnew.ToMM(pad.GetPosition().x),
                                                              pcbnew.ToMM(pad.GetPosition().y)]})
    for t in board.GetTracks():
        if t.GetClass() == "PCB_VIA":
            c = t.GetPosition()
            items.append({"kind": "via", "id": f"via@{pcbnew.ToMM(c.x):.3f},{pcbnew.ToMM(c.y):.3f}",
                          "layer": "*", "at": [pcbnew.ToMM(c.x), pcbnew.ToMM(c.y)],
                          "radius": pcbnew.ToMM(t.GetWidth(pcbnew.F_Cu)) / 2, "net": t.GetNetname()})
        else:
            a, b = t.GetStart(), t.GetEnd()
            items.append({"kind": "track", "id": f"track{len(items)}", "layer": t.GetLayerName(),
                          "start": [pcbnew.ToMM(a.x), pcbnew.ToMM(a.y)], "end": [pcbnew.ToMM(b.x), pcbnew.ToMM(b.y)],
                          "width": pcbnew.ToMM(t.GetWidth()), "net": t.GetNetname()})
    for z in board.Zones():
        for name, lid in COPPER:
            if z.IsOnLayer(lid) and z.HasFilledPolysForLayer(lid):
                fpoly = z.GetFilledPolysList(lid)
                for k, pts in enumerate(_poly_points(fpoly)):
                    items.append({"kind": "zone", "id": f"zone:{z.GetNetname()}:{name}:{k}", "layer": name,
                                  "polys": [pts]})
    json.dump({"items": items}, open(job["result"], "w"))


def main(argv):
    # KiCad gives every item a random UUID, and orders items (hence the Gerber apertures) by them:
    # a seeded generator makes the same job give the same board and the same Gerber bytes
    pcbnew.KIID.SeedGenerator(20240601)
    job = json.load(open(argv[1]))
    {"build": build, "import_ses": import_ses, "copper": copper, "fill": refill}[job["op"]](job)


if __name__ == "__main__":
    main(sys.argv)
