"""Bill of materials generated from the design: every quantity follows hw/sensor.toml.

``bom_rows(design, volumes_mm3, wire)`` is pure: it takes the CAD volumes (``whisker.part_measures.cad_volumes``) and the
coil winding (``coil_wire``) and returns the rows; ``write_bom_csv`` writes them atomically. The
committed ``hw/bom.csv`` is this module's output for the default design (``make bom``); a test
regenerates it and fails when it differs.

Quantity rules (all inputs from the Design unless stated):
- rods, coils, magnets: one per whisker (N = whiskers.count).
- magnet wire: N x (winding wire length + 2 x bom.coil_lead_length) x (1 + bom.wire_waste); the
  winding is the turns that fit the bobbin's window (the coil calculator ``whisker.coil.winding`` on
  the former's window, ``whisker.design.former``).
- screws and heat-set inserts: per fastened joint ([fasteners], the adapter's flange), ISO 4762
  stock lengths for each stack (``whisker.design.fasteners.bom_lines``).
- L298N modules: ceil(N / 2) (two H-bridge channels each); PCA9685 boards when wiring.expander is
  "pca9685": ceil(2 N / 16). Pin counts and jumper wires come from ``whisker.drive.pins.pin_map``.
- series resistors: N when driver.series_resistance resolves to > 0 (``whisker.coil.driver``), power
  rating the smallest common one carrying the 100 % duty, cold-coil dissipation at <= 60 %.
- Ecoflex: membrane CAD volume x (1 + bom.ecoflex_waste), grams with membrane.density.
- PLA, per printed part, three estimates (benchmarks/results/bom.md compares them with the slicer):
  solid = V x density (100 % infill, an upper bound); shell = density x (S + f (V - S)) with the
  shell S = min(V, A x perimeters x extrusion_width) from the CAD volume V and surface area A and the
  infill fraction f of the printer profile (the BOM quantity by default); slicer = the grams PrusaSlicer
  reports (``--print-report``, used as the quantity when given). Plus bom.pla_waste.
- LED strip: the whole cut segments that fit in the LED channel, whose circumference is
  2 pi (cavity_radius + mount.led_strip_thickness). A 5 V strip on the Pi's 5 V header pin
  (``whisker.drive.pins.LED_HEADER_PINS``), not on the coil supply.
- coil supply: N x V_fs / coil.resistance + modules x the L298's quiescent current, rounded up to
  whole amperes: every coil fully on at once (the PWM on-phases all overlapping), V_fs from
  ``whisker.drive.guard.full_scale_voltage`` (the bridge's typical drop; a measured value when set).
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import astuple, dataclass, fields
from pathlib import Path
from typing import Optional

from whisker.design import Design
from whisker.errors import BomError
from whisker.part_measures import (CALIBRATION_PARTS, MEMBRANE_PART, PRINTED_PARTS, RESIN_PARTS, PrintSettings,
                                   cad_measures, pla_grams, print_settings, read_print_report)
from whisker.part_numbers import find_part, with_part_number
from whisker.coil.driver import RESISTOR_LOAD, resistor_power_W, resistor_rating_W, series_resistance_ohm
from whisker.drive.guard import full_scale_voltage
from whisker.drive.pins import (LED_HEADER_PINS, PCA9685_CHANNELS, expander_boards_needed, module_makes_own_logic_supply,
                          modules_needed, pin_map, supply_warnings)

COLUMNS = ("item", "category", "description", "quantity", "unit", "specification", "part_number",
           "example_source", "notes")






@dataclass(frozen=True)
class BomRow:
    item: str
    category: str  # buy | make | print | consumable
    description: str
    quantity: str  # formatted number (kept as text so the CSV is byte-stable)
    unit: str
    specification: str
    part_number: str
    example_source: str
    notes: str

    @property
    def value(self) -> float:
        return float(self.quantity)


@dataclass(frozen=True)
class CoilWire:
    """Winding figures the BOM needs: wire length per coil (mm), where it came from, whether it fits."""

    wire_length_mm: float
    source: str
    fits: Optional[bool] = None
    turns: Optional[int] = None


def coil_wire(design: Design) -> CoilWire:
    """Wire of one coil: the turns that fit the bobbin's winding window at [winding] fill_factor
    (the coil calculator whisker.coil.winding on the former's window, whisker.design.former; no CAD), mm."""
    from whisker.coil import winding

    try:
        w = winding(design)
    except ValueError as err:  # whisker.coil.CoilError: an impossible winding request
        raise BomError(f"coil winding: {err}") from err
    return CoilWire(float(w.wire_length_mm), "the turns that fit the bobbin, whisker.coil.winding",
                    bool(w.fits), int(w.turns))


def _num(x: float, digits: int = 0) -> str:
    if not math.isfinite(x):
        raise BomError(f"non-finite BOM quantity {x}")
    return f"{x:.{digits}f}"


def awg(diameter_mm: float) -> int:
    """Nearest American Wire Gauge of a bare copper diameter: d = 0.127 mm x 92^((36 - n)/39)."""
    return round(36 - 39 * math.log(diameter_mm / 0.127) / math.log(92))


def led_strip(design: Design) -> tuple[float, int, float]:
    """(channel circumference mm, whole segments that fit, strip length mm) for the LED channel
    (whisker.design.sizing.led_strip, which the CAD draws too)."""
    from whisker.design import DesignError, sizing

    try:
        return sizing.led_strip(design)
    except DesignError as err:
        raise BomError(str(err)) from None


#: ST L298 datasheet, electrical characteristics: quiescent supply current IS <= 70 mA (pin 4, inputs
#: high) plus logic current ISS <= 36 mA (pin 9), which the module's 78M05 also draws from VS, A.
L298_QUIESCENT_A = 0.070 + 0.036


def supply_current_A(design: Design) -> float:
    """Coil supply current with every coil fully on at once, A: N x V_fs / R (+ the L298 modules'
    quiescent current). V_fs = ``whisker.drive.guard.full_scale_voltage``: the supply minus the bridge's
    typical drop, shared with the series resistor (8 x 3.22 V / 7 ohm = 3.68 A at 7.5 V; 8 x 5.24 V /
    7 ohm = 5.99 A without the resistor; 8.6 A without the drop either)."""
    coils = design.whiskers.count * full_scale_voltage(design) / design.coil.resistance
    quiescent = modules_needed(design.whiskers.count) * L298_QUIESCENT_A if design.driver.type == "L298N" else 0.0
    return coils + quiescent


# Consumables the build guide (docs/build.md) uses. Estimates, named as such in each row's notes.
HOOKUP_LENGTH_MM = 300.0     # stranded wire per coil lead, the mount's cable exit to the driver (estimate)
SOLDER_G_PER_JOINT = 0.05    # 0.5 mm rosin-core solder per small joint (estimate: ~15 mm of wire)
SAND_G_PER_TIP = 0.1         # fine sand per whisker tip, 10 mm dipped (estimate, with spillage)
#: Fuse ratings (A), IEC 60127 series (5 x 20 mm glass fuses).
FUSE_RATINGS_A = (0.5, 0.63, 0.8, 1.0, 1.25, 1.6, 2.0, 2.5, 3.15, 4.0, 5.0, 6.3, 8.0, 10.0)
#: A fuse carries this fraction of its rating at most (IEC 60127 fuses open slowly from ~1.5 x rating;
#: 0.75 keeps the all-on current clear of nuisance blowing as the fuse warms).
FUSE_LOAD = 0.75


def consumables(d: Design, volumes_mm3: dict[str, float], add) -> None:
    """The consumables the guide's steps use, with quantities (rows added through `add`)."""
    n, b = d.whiskers.count, d.bom
    if RESIN_PARTS[0] in volumes_mm3:
        ml = n * volumes_mm3[RESIN_PARTS[0]] / 1000.0 * (1 + b.pla_waste)
        add("resin", "consumable", "MSLA printer resin for the bobbins", _num(max(ml, 0.01), 2), "ml",
            "standard or tough 405 nm resin, 0.05 mm layers", "any resin vendor",
            f"{n} bobbins + {b.pla_waste:.0%} waste; the vat needs ~50 ml to print at all, so buy a bottle")
    add("release_agent", "consumable", "mould release for silicone on PLA", "1", "can",
        "Ease Release 200 (or a thin petroleum-jelly film)", "Smooth-On", "sprayed on the mould and the lid")
    add("wax", "consumable", "paraffin wax for the rods' glue ends", "1", "pcs",
        "a tea light or paraffin block", "any",
        f"melted over each rod's lowest {d.rod_below_membrane:g} mm before casting, so no silicone film blocks "
        "the coil's glue joint; scraped off after demoulding")
    add("sand", "consumable", "fine sand for the whisker tips", _num(n * SAND_G_PER_TIP, 1), "g",
        "dry quartz sand, 0.1-0.3 mm grain", "craft or aquarium suppliers",
        f"{n} tips x {SAND_G_PER_TIP:g} g (estimate); gives the tips' friction (mechanics.tip_friction = "
        f"{d.mechanics.tip_friction:g})")
    joints = 2 * n + 2 * n + 2  # lead-to-hookup per coil, hookup to resistor/terminal per coil, LED strip
    add("solder", "consumable", "solder", _num(max(1.0, joints * SOLDER_G_PER_JOINT), 1), "g",
        "0.5 mm rosin-core, Sn60Pb40 or SAC305", "any",
        f"{joints} joints x {SOLDER_G_PER_JOINT:g} g (estimate); the enamel strips at ~360 C (solderable wire)")
    add("hookup_wire", "consumable", "hookup wire, coil leads to the driver", _num(2 * n * HOOKUP_LENGTH_MM / 1000, 1),
        "m", "26 AWG stranded, two colours", "any", f"2 x {n} leads x {HOOKUP_LENGTH_MM:g} mm (estimate)")
    add("heat_shrink", "consumable", "heat-shrink sleeve over the lead joints", _num(2 * n), "pcs",
        "1.5 mm, 10 mm pieces", "any", "one per 0.1 mm lead joint")
    amps = supply_current_A(d)
    fuse = next((r for r in FUSE_RATINGS_A if amps <= FUSE_LOAD * r), FUSE_RATINGS_A[-1])
    add("fuse", "consumable", "fuse in the coil supply's + lead", "1", "pcs",
        f"{fuse:g} A slow-blow, 5 x 20 mm, in an inline holder", "any",
        f"all {n} coils fully on draw {amps:.2f} A <= {FUSE_LOAD:.0%} of {fuse:g} A (IEC 60127 series)")


def bom_rows(design: Design, volumes_mm3: dict[str, float], wire: CoilWire,
             print_grams: Optional[dict[str, float]] = None,
             areas_mm2: Optional[dict[str, float]] = None,
             settings: Optional[PrintSettings] = None) -> list[BomRow]:
    """The bill of materials for `design` (pure).

    volumes_mm3 / areas_mm2 from :func:`cad_measures`, settings from :func:`print_settings`: with
    both, PLA is the shell model, else the solid upper bound; print_grams (slicer) override both.
    """
    for name in (*PRINTED_PARTS, MEMBRANE_PART):
        v = volumes_mm3.get(name)
        if v is None or not math.isfinite(v) or v <= 0:
            raise BomError(f"CAD volume of '{name}' is missing or not positive: {v}")
    if not math.isfinite(wire.wire_length_mm) or wire.wire_length_mm <= 0:
        raise BomError(f"coil wire length must be positive and finite, got {wire.wire_length_mm}")

    d = design
    n = d.whiskers.count
    b = d.bom
    channels = pin_map(d)  # raises PinMapError when the Pi cannot serve N coils
    modules = modules_needed(n)
    expander = d.wiring.expander == "pca9685"
    rows: list[BomRow] = []

    def add(item, category, description, quantity, unit, spec, source, notes=""):
        rows.append(BomRow(item, category, description, quantity, unit, spec, "", source, notes))

    w = d.whiskers
    add("rod", "buy", "whisker rod, carbon fibre", _num(n), "pcs",
        f"pultruded carbon-fibre rod, {w.rod_diameter:g} mm dia, cut to {w.rod_length:g} mm",
        "RC/hobby shops: 1 mm x 500 mm carbon rods",
        f"{math.ceil(n * w.rod_length / 500)} x 500 mm stock rod(s); tips coated with sand (paper)")

    c = d.coil
    turns = wire.turns if wire.turns is not None else c.turns
    fit = "" if wire.fits in (None, True) else f"; the design's coil.turns = {c.turns} do not fit the bobbin"
    add("coil", "make", "electromagnet at each whisker base, wound on its bobbin", _num(n), "pcs",
        f"{turns} turns of {c.wire_diameter:g} mm copper on the bobbin's {c.inner_diameter:g} mm core, "
        f"{c.length:g} mm window, {c.outer_diameter:g} mm flange",
        "hand-wound with the winding jig (docs/coil.md)",
        f"the turns that fit at fill {d.winding.fill_factor:g}; red marker dot {c.marker_diameter:g} mm on the "
        f"bobbin tab's lower face{fit}")
    if RESIN_PARTS[0] in volumes_mm3:
        resin_ml = n * volumes_mm3[RESIN_PARTS[0]] / 1000.0 * (1 + b.pla_waste)
        add("bobbin", "print", "coil former (bobbin), resin print", _num(n), "pcs",
            f"MSLA resin, 0.05 mm layers, {volumes_mm3[RESIN_PARTS[0]]:.1f} mm^3 each", "make stl (exports/bobbin.stl)",
            f"rod tab, core, flange; about {resin_ml:.2f} ml of resin for {n} (+{b.pla_waste:.0%} waste); "
            "an FDM printer at 0.4 mm cannot print its 1 mm core")

    per_coil = wire.wire_length_mm + 2 * b.coil_lead_length
    total_m = n * per_coil * (1 + b.wire_waste) / 1000.0
    add("magnet_wire", "buy", "enamelled copper magnet wire", _num(total_m, 1), "m",
        f"{c.wire_diameter:g} mm bare copper (AWG {awg(c.wire_diameter)}), enamel class "
        f"{_limit(d, 'enamel'):g} C",
        "electronics distributors: 0.1 mm enamelled copper wire spool",
        f"{n} coils x ({wire.wire_length_mm / 1000:.2f} m winding [{wire.source}] + 2 x "
        f"{b.coil_lead_length:g} mm leads) + {b.wire_waste:.0%} waste")

    m = d.magnet
    add("magnet", "buy", "NdFeB disc magnet in the mount wall", _num(n), "pcs",
        f"{m.grade} NdFeB disc {m.diameter:g} mm dia x {m.height:g} mm, axially magnetised",
        "magnet suppliers (custom size)", f"N pole faces the coil; max {_limit(d, 'magnet'):g} C")

    mem = d.membrane
    vol_ml = volumes_mm3[MEMBRANE_PART] / 1000.0
    grams = vol_ml * mem.density * (1 + b.ecoflex_waste)
    add("ecoflex", "buy", f"{mem.material} silicone for the membrane", _num(grams, 1), "g",
        f"{mem.material}, 1A:1B by weight, density {mem.density:g} g/cm^3",
        "Smooth-On (trial unit)",
        f"membrane CAD volume {vol_ml:.2f} cm^3 + {b.ecoflex_waste:.0%} waste")

    from whisker.cad.parts import BY_NAME

    rho = d.print.filament_density
    use_shell = settings is not None and areas_mm2 is not None
    use_slicer = bool(print_grams) and all(p in print_grams for p in PRINTED_PARTS)
    pla_total = 0.0
    for name in PRINTED_PARTS:
        solid = pla_grams(volumes_mm3[name], 0.0, rho)
        spec = f"PLA, CAD volume {volumes_mm3[name] / 1000:.2f} cm^3 (solid {solid:.1f} g)"
        g = solid
        if use_shell:
            g = pla_grams(volumes_mm3[name], areas_mm2.get(name, float("nan")), rho, settings)
            spec += f", shell model {g:.1f} g"
        if print_grams and name in print_grams:
            spec += f", slicer {print_grams[name]:.1f} g"
            if use_slicer:
                g = print_grams[name]
        pla_total += g
        add(f"print_{name}", "print", BY_NAME[name].description, "1", "pcs", spec,
            "make stl (exports/)", f"print with exports/{name}.stl")
    for name in CALIBRATION_PARTS:
        add(f"print_{name}", "print", BY_NAME[name].description, "1", "pcs", "PLA, printed once (calibration)",
            "make stl (exports/)", f"print with exports/{name}.stl; not in the sensor's PLA total")
    if use_slicer:
        how = "slicer report (PrusaSlicer, profile infill)"
    elif use_shell:
        how = (f"shell model: {settings.shell_mm:g} mm shell + {settings.infill:.0%} infill from the "
               "printer profile (within 11 % of PrusaSlicer per part, benchmarks/results/bom.md)")
    else:
        how = "solid parts (100 % infill, upper bound)"
    add("pla", "buy", "PLA filament for the printed parts", _num(pla_total * (1 + b.pla_waste), 1), "g",
        f"1.75 mm PLA, density {rho:g} g/cm^3", "any filament vendor",
        f"{len(PRINTED_PARTS)} parts, {how}, + {b.pla_waste:.0%} waste")

    if d.driver.type == "HAT":
        _hat_rows(d, n, add)
    else:
        _module_rows(d, n, modules, expander, add)

    add("raspberry_pi", "buy", "Raspberry Pi 4 Model B", "1", "pcs",
        "2 GB or more, 40-pin header, CSI camera port", "Raspberry Pi approved resellers",
        "runs the camera, tracking and the coil PWM (software PWM on the IN pins)")
    add("pi_supply", "buy", "Raspberry Pi USB-C power supply", "1", "pcs", "5.1 V, 3 A, USB-C",
        "Raspberry Pi approved resellers", "")
    add("microsd", "buy", "microSD card for the Pi OS", "1", "pcs", "16 GB or more, class A1",
        "any", "")

    from whisker.design.camera_boards import profile

    cam = d.camera
    prof = profile(cam.board)
    add("camera", "buy", f"camera board: {prof.title}", "1", "pcs",
        f"board {prof.board.width:g} x {prof.board.height:g} mm, holes {prof.holes.spacing_x:g} x "
        f"{prof.holes.spacing_y:g} mm, used at {cam.width_px} x {cam.height_px} (camera.board = {cam.board})",
        "Raspberry Pi camera boards", "focus the lens on the coil plane")
    if find_part("lens", d):
        add("lens", "buy", "M12 x 0.5 lens for the camera board", "1", "pcs",
            "M12 x 0.5 (S-mount), 1/4 in sensor format, about 160 deg field of view", "M12 lens makers",
            "often sold with the board; whisker calibrate camera measures its distortion")
    add("csi_cable", "buy", "camera flat cable", "1", "pcs",
        f"15-pin 1 mm pitch CSI ribbon, {d.mount.ribbon_width:g} mm wide, 300 mm",
        "Raspberry Pi approved resellers", "leaves the mount through the ribbon slot at -y")

    circ, segments, strip_mm = led_strip(d)
    add("led_strip", "buy", "LED strip lighting the coils", _num(strip_mm), "mm",
        f"5 V 3528 LED strip, {d.mount.led_strip_width:g} mm wide, {segments} segment(s) of "
        f"{b.led_cut_pitch:g} mm", "any 5 V 3528 strip (60 LED/m)",
        f"LED channel circumference {circ:.1f} mm = 2 pi (cavity radius + strip thickness); whole "
        f"segments only; powered from the Pi's 5V header pin {LED_HEADER_PINS[0]} (GND pin "
        f"{LED_HEADER_PINS[1]}), not the {d.driver.supply_voltage:g} V coil supply")

    amps = supply_current_A(d)
    add("coil_supply", "buy", "DC supply for the coils", "1", "pcs",
        f"{d.driver.supply_voltage:g} V regulated, at least {math.ceil(amps)} A",
        "bench supply or regulated wall adapter",
        f"{amps:.2f} A with all {n} coils fully on at once ({full_scale_voltage(d):.2f} V at each "
        f"{c.resistance:g} ohm coil after the bridge drop{' and series resistor' if series_resistance_ohm(d) > 0 else ''}) and the "
        "modules' quiescent current; "
        "share its GND with the Pi")

    signal = sum(2 + (ch.enable is not None) for ch in channels)  # source -> IN (and EN) per coil
    spare = 2 if n % 2 else 0  # IN3/IN4 of a half-used module tied to a Pi GND pin (as in the netlist)
    bus = 4 * expander_boards_needed(n) if expander else 0  # 3V3, GND, SDA, SCL per PCA9685 board
    jumpers = signal + 1 + 2 + spare + bus  # + one Pi GND -> supply GND (the common ground), + 2 LED
    vs = d.driver.supply_voltage
    if d.driver.type != "HAT":  # the HAT plugs onto the header: no jumpers, power on its own terminal
        add("jumpers", "buy", "female-female jumper wires", _num(jumpers), "pcs",
            "2.54 mm Dupont, 20 cm", "any",
            f"from the pin map (hw/pcb/generated/pinout.md): {signal} signal + 1 Pi GND to the supply GND"
            " + 2 LED strip to the Pi's 5V and GND (cut one end, solder it to the strip)"
            + (f" + {spare} tying the spare IN3/IN4 to GND" if spare else "")
            + (f" + {bus} for the PCA9685 bus (3V3, GND, SDA, SCL per board)" if bus else ""))
        add("power_wire", "buy", "power wire supply -> modules", _num(2 * modules), "pcs",
            "22 AWG stranded, red/black", "any", f"+{vs:g} V and GND to each module's screw terminals")

    from whisker.design import fasteners as fz

    fastener_parts = {}
    for line in fz.bom_lines(design_joints(d)):
        fastener_parts[line["item"]] = line
        add(line["item"], "buy", "screw" if line["item"].startswith("screw") else "heat-set insert",
            _num(line["quantity"]), line["unit"], line["specification"],
            "any fastener supplier", line["notes"]
            + ("; the cover's only without the adapter" if "camera cover" in line["notes"] else ""))

    add("glue", "consumable", "glue for rods, coils, magnets", "1", "set",
        "silicone adhesive for rod-membrane joints; cyanoacrylate for coils on rods and magnets in "
        "pockets", "Smooth-On Sil-Poxy; any CA glue", "")
    add("paint", "consumable", "paint: grey membrane top, red coil markers", "1", "set",
        "silicone-compatible grey paint; red paint marker", "any", "")
    consumables(d, volumes_mm3, add)

    rows = [with_part_number(r, d, fastener_parts.get(r.item)) for r in rows]
    for r in rows:  # one-line fields keep the CSV diffable
        for f in fields(r):
            if "\n" in getattr(r, f.name):
                raise BomError(f"BOM field {f.name} of {r.item} contains a newline")
    return rows


def design_joints(design: Design) -> list:
    """Every fastened joint of the design (whisker.design.fasteners.Joint): the camera board's screws,
    the adapter's (mount, flange plate, robot) and the camera cover's."""
    from whisker.design import fasteners as fz
    from whisker.cad.solids import adapter, cover

    f = design.fasteners
    return [fz.Joint("camera board", f.camera_screw, f.camera_joint, 4, design.camera.board_thickness),
            *adapter.joints(design), *cover.joints(design)]


def bom_csv(rows: list[BomRow]) -> str:
    """CSV text (header + rows, \\n line ends) of a BOM."""
    buf = io.StringIO()
    wr = csv.writer(buf, lineterminator="\n")
    wr.writerow(COLUMNS)
    for r in rows:
        wr.writerow(astuple(r))
    return buf.getvalue()


def make_bom(design: Design, print_report: str | Path | None = None) -> list[BomRow]:
    """The BOM with CAD volumes measured now and the coil calculator's wire length."""
    pin_map(design)  # refuse an unwireable design before building any CAD
    grams = read_print_report(print_report, design) if print_report else None
    volumes, areas = cad_measures(design)
    return bom_rows(design, volumes, coil_wire(design), grams, areas, print_settings(design))


def write_bom_csv(rows: list[BomRow], path: str | Path) -> Path:
    from whisker.files import atomic_write_text

    path = Path(path)
    atomic_write_text(path, bom_csv(rows))
    return path


def _module_rows(d, n, modules, expander, add) -> None:
    """The paper's drive: L298N modules, series resistors, PCA9685 boards (driver.type = "L298N")."""
    vs = d.driver.supply_voltage
    jumper = ("5V-EN jumper fitted (its regulator makes the logic supply)" if module_makes_own_logic_supply(d)
              else f"5V-EN jumper removed (fed {vs:g} V on +12V and +5V)")
    cautions = "".join(f"; CAUTION: {w}" for w in supply_warnings(d))
    add("h_bridge", "buy", f"{d.driver.type} dual H-bridge module", _num(modules), "pcs",
        f"2 channels each (IN1/IN2/ENA, IN3/IN4/ENB), ENA/ENB jumpers fitted, {jumper}",
        "common L298N motor-driver boards",
        f"ceil({n}/2); PWM on IN1/IN2 sets the mean coil voltage (docs/wiring.md){cautions}")

    rs = series_resistance_ohm(d)
    if rs > 0:
        p_rs = resistor_power_W(d)
        try:
            rating = resistor_rating_W(p_rs)
        except ValueError as err:  # whisker.coil.driver.DriverError: no common part carries it
            raise BomError(f"series resistor: {err}") from err
        add("series_resistor", "buy", "series resistor per coil (the paper's voltage dividing circuit)", _num(n),
            "pcs", f"{rs:g} ohm, {rating:g} W, 5 %, metal oxide or wirewound, axial",
            "any electronics distributor",
            f"one between each L298N output and its coil (driver.series_resistance); {p_rs:.2f} W at 100 % "
            f"duty into a cold coil, <= {RESISTOR_LOAD:.0%} of the rating; caps the coil at "
            f"{full_scale_voltage(d):.2f} V <= drive.max_coil_voltage={d.drive.max_coil_voltage:g} V "
            f"even when a GPIO sticks high")

    if expander:
        boards = expander_boards_needed(n)
        add("pwm_expander", "buy", "PCA9685 16-channel I2C PWM board", _num(boards), "pcs",
            f"I2C at 0x{d.wiring.pca9685_address:02X}.. (address jumpers), {PCA9685_CHANNELS} channels, "
            "3.3 V logic from the Pi",
            "Adafruit 815 or compatible", f"2 channels per coil: ceil(2 x {n} / 16)")


def _hat_rows(d, n, add) -> None:
    """The generated driver HAT (driver.type = "HAT"): one assembled board and a pigtail per coil."""
    from whisker.coil.board import full_scale_current_A, sense_resistance_ohm

    add("driver_hat", "make", "whisker driver HAT (Raspberry Pi HAT, 4-layer PCB, assembled)", "1", "pcs",
        f"{n} coil channels: {math.ceil(n / 2)} x {d.driver.bridge}, {math.ceil(n / 3)} x {d.driver.current_monitor} "
        f"({sense_resistance_ohm(d):g} ohm sense), supply {d.driver.supply_voltage:g} V, "
        f"{full_scale_current_A(d):.2f} A per coil full scale",
        "order with hw/pcb/generated/hat/gerbers + bom_jlcpcb.csv + cpl_jlcpcb.csv (make pcb; JLCPCB format)",
        "docs/wiring.md; replaces the L298N modules, series resistors and jumper wires")
    add("coil_pigtail", "buy", "JST PH 2-pin housing with two pre-crimped leads", _num(n), "pcs",
        "JST PHR-2 + 2 x SPH-002T-P0.5S, 26-28 AWG, ~100 mm", "JST / pre-crimped PH lead kits",
        "one per coil: solder the coil's thin leads to the pigtail, plug into W0..")


def _limit(design, role: str) -> float:
    """A part's temperature limit from the thermal material table (whisker.coil.thermal_materials), C."""
    from whisker.coil.thermal_materials import limit_C
    return limit_C(design, role)
