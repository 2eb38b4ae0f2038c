"""Placement and design rules of the HAT, by code from the design (no KiCad needed here).

The board is the HAT outline of hw/rpi_hat.toml (65 x 56.5 mm, four M2.5 holes, the 40-pin header).
Four copper layers: F.Cu and B.Cu carry the routed signals, In1.Cu is a solid GND plane and In2.Cu a
solid VM (coil supply) plane, so the coil current never depends on a thin routed supply trace and every
GND/VM pad reaches its plane through its own via (placed here, ``fanout``).

Floor plan (y down from the header edge):
- coil connectors in whisker order along the bottom edge (then up the left and right edges when
  there are more than ``BOTTOM_SLOTS``), clear of the mounting holes;
- a row of DRV8833s above them, each centred over its two coils, its sense resistors beside its
  outputs, VM/VCP/VINT capacitors above its supply pins (datasheet layout: caps at the pins);
- the INA3221 row above the bridges; the ID EEPROM by header pins 27/28; PCA9685s top left;
- the supply (terminal, fuse, reverse-polarity P-FET, bulk capacitor) in the right column.

Trace widths: IPC-2221 external-layer chart fit, I = k dT^0.44 A^0.725 (A in mil^2, k = 0.048), for the
largest current each net class carries at a 10 K rise in 1 oz (35 um) copper.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass

from whisker.coil import board as coil_board
from whisker.design import Design
from whisker.resources import hw_dir

from .hat import Hat, pad_nets

HAT_SPEC = "rpi_hat.toml"
#: IPC-2221 external conductor constant and exponents (I in A, dT in K, A in mil^2).
IPC_K_EXTERNAL, IPC_B, IPC_C = 0.048, 0.44, 0.725
COPPER_OZ_MIL = 1.378          # 1 oz/ft^2 copper = 35 um = 1.378 mil
TEMP_RISE_K = 10.0            # K, steady: every coil at full scale
FAULT_RISE_K = 30.0           # K, a fault: a stuck output held at the bridge's chopper limit
#: Fab limits we stay well inside (JLCPCB 4-layer standard: 0.09 mm track/space, 0.2 mm drill).
CLEARANCE_MM = 0.2
MIN_TRACK_MM = 0.2
VIA_MM, VIA_DRILL_MM = 0.45, 0.2
EDGE_CLEARANCE_MM = 0.2
POWER_NETS = ("GND", "VM")                      # planes: In1.Cu and In2.Cu
PLANE_LAYER = {"GND": "In1.Cu", "VM": "In2.Cu"}
BOTTOM_SLOTS = 9
#: the bridge's capacitor row above its supply pins: room for their plane vias and the VCP/VINT tracks
CAP_ROW_MM = 6.2
SLOT_PITCH_MM = 7.1             # JST PH vertical courtyard is 7.0 mm wide


def hat_spec() -> dict:
    with open(hw_dir() / HAT_SPEC, "rb") as fh:
        return tomllib.load(fh)


def ipc2221_width_mm(current_A: float, rise_K: float = TEMP_RISE_K, oz: float = 1.0) -> float:
    """Track width for `current_A` on an outer layer (IPC-2221 chart fit), mm."""
    if not (current_A > 0 and math.isfinite(current_A)):
        raise ValueError(f"current must be positive (got {current_A!r} A)")
    area_mil2 = (current_A / (IPC_K_EXTERNAL * rise_K ** IPC_B)) ** (1 / IPC_C)
    return area_mil2 / (COPPER_OZ_MIL * oz) * 0.0254


@dataclass(frozen=True)
class Rules:
    coil_current_A: float       # the most a coil track carries: the bridge's chopper cap
    coil_width: float
    supply_current_A: float     # every coil at full scale
    supply_width: float
    track_width: float          # default (routed) width = the coil width, rounded up to 0.05 mm

    def as_dict(self) -> dict:
        return {"clearance": CLEARANCE_MM, "min_track": MIN_TRACK_MM, "track_width": self.track_width,
                "via_diameter": VIA_MM, "via_drill": VIA_DRILL_MM, "edge_clearance": EDGE_CLEARANCE_MM,
                "hole_clearance": 0.25, "coil_width": self.coil_width, "supply_width": self.supply_width,
                "coil_current_A": self.coil_current_A, "supply_current_A": self.supply_current_A}


def rules(design: Design) -> Rules:
    """Track widths from the currents: a coil track carries the full-scale current (10 K rise) and, on a
    fault, at most the chopper cap (the upper trip, 30 K rise); the wider of the two."""
    cap = coil_board.chopper_trip_A(design)[1]
    i_fs = coil_board.full_scale_current_A(design)
    i_coil = cap if math.isfinite(cap) else i_fs
    w_coil = max(ipc2221_width_mm(i_fs), ipc2221_width_mm(i_coil, FAULT_RISE_K))
    i_supply = design.whiskers.count * coil_board.full_scale_current_A(design)
    w = max(MIN_TRACK_MM, math.ceil(w_coil / 0.05 - 1e-9) * 0.05)
    return Rules(i_coil, w_coil, i_supply, ipc2221_width_mm(i_supply / 2), round(w, 2))


def connector_slots(n: int, spec: dict) -> list[tuple[float, float, float]]:
    """(x, y, rotation) of pad 1 of each coil connector, in whisker order along the edges."""
    w, h = spec["board"]["width"], spec["board"]["height"]
    y = h - 10.5
    bottom = min(n, BOTTOM_SLOTS if n > 8 else n)
    extra = n - bottom
    # the (at most 3) coils beyond the bottom row go up the left edge: the right edge is the supply's
    left, right = extra, 0
    slots = []
    for k in range(left):  # left edge, top to bottom, leads entering from above
        slots.append((3.5, y - 8.0 - 7.5 * (left - 1 - k), 90.0))
    x0 = w / 2 - SLOT_PITCH_MM * (bottom - 1) / 2
    for k in range(bottom):
        slots.append((x0 + SLOT_PITCH_MM * k - 1.0, y, 0.0))
    for k in range(right):  # right edge, bottom to top
        slots.append((w - 3.5, y - 8.0 - 7.5 * k, 270.0))
    return slots


def place(hat: Hat) -> dict:
    """The board spec for whisker.pcb.kicad_job: parts with positions and pad nets, holes, zones, rules."""
    d = hat.design
    spec = hat_spec()
    W, H = spec["board"]["width"], spec["board"]["height"]
    n = d.whiskers.count
    nets = pad_nets(hat)
    parts: list[dict] = []
    at: dict[str, tuple[float, float, float, str]] = {}

    def put(ref, x, y, rot=0.0, side="top"):
        at[ref] = (round(x, 3), round(y, 3), rot, side)

    # header: pad 1 where the spec puts it (socket under the board)
    cx, cy = spec["header"]["centre"]
    pitch = spec["header"]["pitch"]
    put("J1", cx - 9.5 * pitch, cy + pitch / 2, 270.0, "bottom")

    slots = connector_slots(n, spec)
    for i, (x, y, r) in enumerate(slots):
        put(f"J{10 + i}", x, y, r)
    nb = math.ceil(n / 2)
    # bridges: centred over their coils' connectors on the bottom row, else evenly in the left part
    y_drv = H - 23.0
    span = (7.5 if any(s[2] == 90.0 for s in slots) else 1.5, W - 14.0)   # clear of a left connector column
    xs = []
    for k in range(nb):
        cons = [slots[i] for i in (2 * k, 2 * k + 1) if i < n]
        bottom = [s[0] + 1.0 for s in cons if s[2] == 0.0]
        xs.append(sum(bottom) / len(bottom) if bottom else None)
    pitch_drv = (span[1] - span[0]) / nb
    even = [span[0] + pitch_drv * (k + 0.5) for k in range(nb)]
    if any(x is None for x in xs) or any(b - a < 8.0 for a, b in zip(xs, xs[1:])) or xs[-1] > span[1] - 3:
        xs = even
    cap_refs = _refs_by_net_pair(hat)
    for k, x in enumerate(xs):
        u = f"U{k + 1}"
        put(u, x, y_drv, 90.0)
        # sense resistors beside the chip, vertical, below its pad rows
        off = min(3.6, (xs[1] - xs[0]) / 2 - 1.2) if nb > 1 else 3.6
        for i, sgn in ((2 * k, -1), (2 * k + 1, 1)):
            r = cap_refs.get(("ISEN%d" % i, "GND"))
            if r and i < n:
                put(r, x + sgn * off, y_drv + 7.0, 90.0)
        # caps above the supply pins: VINT over pin 14 (x-0.97), VCP over pin 11 (x+0.97), their plane pads
        # on top (vias upward), so the input pins at both row ends (15/16, 9/10) escape straight up beside
        # them; the VM cap (both pads on planes) one row higher, lying, its vias left and right
        for net_pair, dx, dy, rot in (((f"U{k + 1}_VINT", "GND"), -1.0, CAP_ROW_MM, 90.0),
                                      (("VM", "GND"), 0.0, CAP_ROW_MM + 2.9, 0.0),
                                      ((f"U{k + 1}_VCP", "VM"), 1.0, CAP_ROW_MM, 90.0)):
            ref = cap_refs.pop(net_pair, None) if net_pair[0] != "VM" else _pop_vm_cap(cap_refs, k)
            if ref:
                put(ref, x + dx, y_drv - dy, rot)
    # monitors: centred over the bridges of their coils (evenly over the span when there are four: the
    # centres of overlapping bridge pairs would put two monitors within a package width)
    y_ina = y_drv - 14.0
    mons = sorted(r for r in hat.parts if r.startswith("U1") and len(r) == 3)
    for m, ref in enumerate(mons):
        ks = sorted({c // 2 for c in range(3 * m, min(3 * m + 3, n))})
        x = sum(xs[k] for k in ks) / len(ks)
        if len(mons) > 3:
            x = span[0] + (span[1] - span[0]) * (m + 0.5) / len(mons)
        put(ref, x, y_ina, 0.0)
        c = _pop_vcc_cap(cap_refs)
        put(c, x + 3.8, y_ina - 1.5, 270.0)   # GND pad (and its via) down, away from a PCA9685 above
    # PCA9685s top left
    for k, ref in enumerate(sorted(r for r in hat.parts if r.startswith("U2") and len(r) == 3)):
        put(ref, 12.5 + 13.0 * k, 11.4, 90.0)
        put(_pop_vcc_cap(cap_refs), 12.5 + 13.0 * k + 6.3, 11.4, 90.0)
    # EEPROM near header pins 27/28, its pull-ups and WP jumper beside it
    x_id = cx - 9.5 * pitch + 13 * pitch
    put("U31", x_id, 13.0, 0.0)
    put(_pop_vcc_cap(cap_refs), x_id + 5.0, 14.0, 90.0)
    put(cap_refs.pop(("ID_SD", "+3V3")), x_id - 6.0, 8.6, 0.0)
    put(cap_refs.pop(("ID_SC", "+3V3")), x_id - 6.0, 10.7, 0.0)
    put(cap_refs.pop(("EE_WP", "+3V3")), x_id - 6.0, 12.8, 0.0)
    put("JP1", x_id - 6.0, 15.0, 0.0)
    # supply column on the right
    xr = W - 7.0
    put("J2", W - 5.6, 14.6, 90.0)
    put("F1", xr - 1.5, 23.0, 90.0)
    put("Q1", xr - 1.5, 30.5, 0.0)
    put(cap_refs.pop(("QG", "GND")), xr + 4.2, 30.5, 90.0)
    put("C100", xr - 1.5, 38.5, 90.0)
    put("J3", 3.2, 14.0, 90.0)
    missing = [r for r in hat.parts if r not in at]
    if missing:
        raise ValueError(f"layout places no position for {missing}")
    for ref, (x, y, rot, side) in sorted(at.items(), key=lambda kv: _ref_key(kv[0])):
        info = hat.info[ref]
        parts.append({"ref": ref, "value": info["value"], "footprint": info["footprint"], "x": x, "y": y,
                      "rot": rot, "side": side, "pads": nets.get(ref, {}),
                      "fields": {"MPN": info["mpn"]} if info["mpn"] else {}})
    for k, (x, y) in enumerate(spec["mounting_holes"]["positions"]):
        parts.append({"ref": f"H{k + 1}", "value": "M2.5", "footprint": "MountingHole:MountingHole_2.7mm_M2.5",
                      "x": x, "y": y, "rot": 0.0, "side": "top", "pads": {}, "show_ref": False,
                      "exclude_from_pos": True, "exclude_from_bom": True})
    r = rules(d)
    inset = 0.3
    outline = [[inset, inset], [W - inset, inset], [W - inset, H - inset], [inset, H - inset]]
    zones = [{"net": net, "layer": PLANE_LAYER[net], "polygon": outline, "clearance": CLEARANCE_MM,
              "priority": 0} for net in POWER_NETS]
    texts = [{"text": f"W{i}", "x": x + (1.0 if rot == 0 else 0.0) + (3.2 if rot == 90 else -3.2 if rot == 270 else 0.0),
              "y": y + 4.4 if rot == 0 else y - 1.0, "size": 1.0} for i, (x, y, rot) in enumerate(slots)]
    texts.append({"text": f"whisker HAT {n} coils", "x": W / 2 - 6, "y": 9.0, "size": 1.0})
    texts.append({"text": f"+{d.driver.supply_voltage:g}V", "x": W - 3.5, "y": 4.8 + 14.0, "size": 0.9})
    return {"board": {**spec["board"], "layers": 4}, "rules": r.as_dict(), "parts": parts, "zones": zones,
            "texts": texts, "power_nets": list(POWER_NETS), "plane_layer": PLANE_LAYER,
            "wide_nets": {"VIN": r.supply_width, "VIN_F": r.supply_width}}


def _ref_key(ref: str):
    head = ref.rstrip("0123456789")
    return head, int(ref[len(head):] or 0)


def _refs_by_net_pair(hat: Hat) -> dict:
    """(net of pad 1, net of pad 2) -> ref of every two-pad R/C (first one wins; VM caps kept in a list)."""
    nets = pad_nets(hat)
    out: dict = {"_vm": [], "_vcc": []}
    for ref in sorted(hat.parts, key=_ref_key):
        if ref[0] not in "RC" or ref == "C100":
            continue
        pair = (nets[ref].get("1"), nets[ref].get("2"))
        if pair == ("VM", "GND"):
            out["_vm"].append(ref)
        elif pair == ("+3V3", "GND"):
            out["_vcc"].append(ref)
        else:
            out.setdefault(pair, ref)
    return out


def _pop_vm_cap(refs: dict, k: int):
    return refs["_vm"].pop(0) if refs["_vm"] else None


def _pop_vcc_cap(refs: dict):
    return refs["_vcc"].pop(0)
