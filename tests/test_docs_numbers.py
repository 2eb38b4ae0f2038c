"""Every dimension the docs state agrees with the CAD (exports/manifest.json of the default build),
the design model or the generated BOM (hw/bom.csv).

How: each statement is a regex over the doc's text (whitespace collapsed) with one group per number,
and a function of the built design giving the values the numbers must equal (to the digits the doc
writes). The expected values are computed, never typed, so a change in the CAD or the design that
leaves a doc behind fails here, and so does a statement whose wording changed (not found).

Coverage: in the CAD docs (FILES) every number followed by "mm" must lie inside a checked statement
or inside an EXEMPT phrase, which says why it is not a CAD dimension (a command-line example, a
benchmark or slicer measurement, a paper or tool setting, another design). A new "mm" number in
those docs therefore has to be classified here. Print times and slicer grams are measurements
(docs/printing.md, make check-print), not dimensions, and are excluded.
"""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import pytest

from conftest import load_manifest
from whisker.design import fasteners
from whisker.design import flanges
from whisker.cad.solids import adapter
from whisker.design import default_design

ROOT = Path(__file__).resolve().parents[1]
FILES = ("README.md", "docs/printing.md", "docs/bom.md", "docs/assembly.md")
WORDS = {"six": 6, "eight": 8, "twelve": 12}


def _text(name: str) -> str:
    return re.sub(r"\s+", " ", (ROOT / name).read_text())


class Ctx:
    def __init__(self, manifest: dict):
        self.d = default_design()
        self.m = manifest
        self.bom = {r["item"]: r for r in csv.DictReader((ROOT / "hw" / "bom.csv").open())}

    def size(self, part: str, key: str = "print_bbox_mm") -> list[float]:
        return self.m["parts"][part][key]["size"]

    def qty(self, item: str) -> float:
        return float(self.bom[item]["quantity"])

    def spec_number(self, item: str, pattern: str, field: str = "specification") -> float:
        return float(re.search(pattern, self.bom[item][field]).group(1))


def _get(obj, dotted: str):
    for k in dotted.split("."):
        obj = getattr(obj, k)
    return obj


def _pla(c: Ctx, which: str) -> float:
    return sum(c.spec_number(f"print_{p}", rf"{which} ([\d.]+) g") for p in
               ("mount", "mold_base", "mold_lid", "whisker_ring", "adapter", "flange_plate", "cover", "winding_jig"))


def _leads(c: Ctx) -> dict:
    from whisker.design import leads
    return leads.length_report(c.d)


def _bom_for(n: int, *sets: str):
    from whisker import bom
    d = default_design(f"whiskers.count={n}", *sets)
    vols = {p: 1000.0 for p in (*bom.PRINTED_PARTS, *bom.RESIN_PARTS, bom.MEMBRANE_PART)}
    return {r.item: r for r in bom.bom_rows(d, vols, bom.coil_wire(d))}


EXPANDER = 'wiring.expander="pca9685"'


def _series(c: Ctx) -> list[float]:
    """hw/sensor.toml's worked series-resistor rule (whisker.coil.driver.series_resistance_ohm)."""
    from whisker.coil import driver
    d = c.d
    b, rc, vs, vmax = driver.bridge(d.driver.type), d.coil.resistance, d.driver.supply_voltage, d.drive.max_coil_voltage
    rs = driver.series_resistance_ohm(d)
    p = driver.resistor_power_W(d)
    return [rc, vs - b.v0_typ, vmax, rc + b.r_typ, rc * (vs - b.v0_typ) / vmax - rc - b.r_typ, rs,
            driver.plan(d)["coil_V_full_on_design"], p, driver.resistor_rating_W(p)]


def _full_scale(c: Ctx) -> list[float]:
    """hw/sensor.toml's full-scale voltage comment: with the design's resistor and without one."""
    from whisker.coil import driver
    d = c.d
    p = driver.plan(d)
    v, v0 = p["coil_V_full_on_design"], p["coil_V_full_on"]
    return [v, d.driver.supply_voltage, driver.series_resistance_ohm(d), d.coil.resistance,
            d.actuation.voltage / v, v0, d.actuation.voltage / v0, d.drive.max_coil_voltage / v0]

#: (file, statement regex, expected values of its groups). Numbers compare to the doc's digits.
CHECKS = [
    # README: the sensor, the sizing table, the parts
    ("README.md", r"(\w+) carbon-fibre whiskers on a ([\d.]+) mm circle",
     lambda c: [c.d.whiskers.count, c.d.whiskers.ring_radius]),
    *[("README.md", rf"\| `{key}` \|[^|]*\| ([\d.]+) mm \|", (lambda k: lambda c: [_get(c.d, k)])(key))
      for key in ("membrane.inscribed_radius", "camera.distance", "mold.pour_diameter", "mount.outer_radius",
                  "mount.mounting_bolt_radius")],
    ("README.md", r"`mold.draft_deg` \(([\d.]+) deg\)", lambda c: [c.d.mold.draft_deg]),
    ("README.md", r"`mold.rod_slack` \(([\d.]+) mm\)", lambda c: [c.d.mold.rod_slack]),
    ("README.md", r"(\d+) coupling screws go down", lambda c: [c.d.adapter.coupling_count]),
    ("README.md", r"Two plates because a ([\d.]+) mm flange", lambda c: [flanges.flange("iso9409_31_5_4_m5").pitch_diameter]),
    ("README.md", r"The default mount is ([\d.]+) mm across and ([\d.]+) mm tall",
     lambda c: c.size("mount", "bbox_mm")[1:]),
    ("README.md", r"The camera distance \(([\d.]+) mm\) and the marker size \(([\d.]+) mm\)",
     lambda c: [c.d.camera.distance, c.d.coil.marker_diameter]),
    ("README.md", r"their ([\d.]+) mm ring measures ([\d.]+) mm/px", lambda c: [c.d.whiskers.ring_radius, c.d.mm_per_px]),
    ("README.md", r"coil former \(MSLA resin, ([\d.]+) mm; an FDM nozzle cannot print its ([\d.]+) mm core\)",
     lambda c: [0.05, c.d.coil.inner_diameter]),
    ("README.md", r"PLA \(Prusa MK3S, ([\d.]+) mm nozzle, ([\d.]+) mm layers",
     lambda c: [c.d.print.nozzle_diameter, c.d.print.layer_height]),
    ("README.md", r"For the paper's coil: \d+ turns of ([\d.]+) mm wire do \*\*not\*\* fit (\d+) x (\d+) mm",
     lambda c: [c.d.coil.wire_diameter, c.d.coil.outer_diameter, c.d.coil.length]),
    ("README.md", r"\*\*(\d+) turns, ([\d.]+) ohm\*\*", lambda c: [c.d.coil.turns, c.d.coil.resistance]),
    ("docs/raspberry-pi.md", r"the series resistor of hw/bom.csv \(([\d.]+) ohm, ([\d.]+) W",
     lambda c: [c.spec_number("series_resistor", r"^([\d.]+) ohm"), c.spec_number("series_resistor", r", ([\d.]+) W,")]),
    ("docs/assembly.md", r"each needs at least (\d+) mm from the winding out through the wall, and swinging "
     r"changes its taut path by up to ([\d.]+) mm",
     lambda c: [_leads(c)["needed_to_outside_mm"], _leads(c)["swing_slack_mm"]]),
    # printing: the profile, the refusal example, the size of every printed part
    ("docs/printing.md", r"([\d.]+) mm nozzle, generic PLA \(([\d.]+) mm, ([\d.]+) g/cm\^3, [^)]*\), ([\d.]+) mm layers",
     lambda c: [c.d.print.nozzle_diameter, 1.75, c.d.print.filament_density, c.d.print.layer_height]),
    ("docs/printing.md", r"mount: fits printer = ([\d.]+) mm, needs <= bed 120 x 120 x 50: part is ([\d.]+) x ([\d.]+) x ([\d.]+) mm",
     lambda c: [c.size("mount")[2], *c.size("mount")]),
    ("docs/printing.md", r"down to the ([\d.]+) mm camera screw pilot holes",
     lambda c: [fasteners.hole(c.d.fasteners.camera_screw, c.d.fasteners.camera_joint).diameter]),
    ("docs/printing.md", r"blind ([\d.]+) mm pockets", lambda c: [c.d.magnet.diameter]),
    ("docs/printing.md", r"Default design \((\d+) whiskers on a ([\d.]+) mm ring\)",
     lambda c: [c.d.whiskers.count, c.d.whiskers.ring_radius]),
    ("docs/printing.md", r"\(default ([\d.]+), ([\d.]+), ([\d.]+), ([\d.]+), ([\d.]+) mm, radial\)",
     lambda c: list(c.d.print.coupon_clearances)),
    # bom: the default design's numbers, from hw/bom.csv
    ("docs/bom.md", r"\| rods, coils, magnets \| (\d+) each \|", lambda c: [c.qty("rod")]),
    ("docs/bom.md", r"\| magnet wire \| ([\d.]+) m of ([\d.]+) mm \(AWG (\d+)\): (\d+) x \(([\d.]+) m winding \+ ([\d.]+) m leads\) x ([\d.]+) \|",
     lambda c: [c.qty("magnet_wire"), c.d.coil.wire_diameter, 38, c.d.whiskers.count,
                c.spec_number("magnet_wire", r"\(([\d.]+) m winding", "notes"), 2 * c.d.bom.coil_lead_length / 1000,
                1 + c.d.bom.wire_waste]),
    ("docs/bom.md", r"\| Ecoflex 00-30 \| ([\d.]+) g \(membrane ([\d.]+) cm\^3\) \|",
     lambda c: [c.qty("ecoflex"), c.m["parts"]["membrane"]["volume_mm3"] / 1000]),
    ("docs/bom.md", r"\| PLA \| ([\d.]+) g \(shell model ([\d.]+) g \+ (\d+) %\) for the (\d+) sensor parts; solid upper bound ([\d.]+) g \|",
     lambda c: [c.qty("pla"), _pla(c, "shell model"), 100 * c.d.bom.pla_waste, 8, _pla(c, "solid")]),
    ("README.md", r"For the default design that is ([\d.]+) m of wire, ([\d.]+) g of Ecoflex, (\d+) g of PLA and (\d+) L298N",
     lambda c: [c.qty("magnet_wire"), c.qty("ecoflex"), c.qty("pla"), c.qty("h_bridge")]),
    ("docs/bom.md", r"\| L298N modules \| (\d+) \|", lambda c: [c.qty("h_bridge")]),
    ("docs/bom.md", r"\| LED strip \| (\d+) mm \((\d+) segments; the channel is ([\d.]+) mm around\) \|",
     lambda c: [c.qty("led_strip"), c.qty("led_strip") / c.d.bom.led_cut_pitch,
                c.spec_number("led_strip", r"circumference ([\d.]+) mm", "notes")]),
    ("docs/bom.md", r"\| jumpers / power wires \| (\d+) / (\d+) \|", lambda c: [c.qty("jumpers"), c.qty("power_wire")]),
    ("docs/bom.md", r"`coil_lead_length` ([\d.]+) mm, `ecoflex_waste` ([\d.]+), `pla_waste` ([\d.]+) and `led_cut_pitch` ([\d.]+) mm",
     lambda c: [c.d.bom.coil_lead_length, c.d.bom.ecoflex_waste, c.d.bom.pla_waste, c.d.bom.led_cut_pitch]),
    ("docs/bom.md", r"gives 6/8/12 rods, coils and magnets, 3/4/6 L298N modules, 0/0/2 PCA9685 boards, ([\d.]+)/([\d.]+)/([\d.]+) m of wire",
     lambda c: [_bom_for(6)["magnet_wire"].value, _bom_for(8)["magnet_wire"].value,
                _bom_for(12, EXPANDER)["magnet_wire"].value]),
    ("docs/bom.md", r"`ISO 4762 - M3 x (\d+) - 8.8 \(DIN 912 M3 x (\d+)\)`",
     lambda c: [fasteners.screw_length("M3", "insert", adapter.layout(c.d)["thickness"] - 3.5)[0]] * 2),
    # the design file's comments (hw/sensor.toml): the driver numbers the build and the BOM use
    ("hw/sensor.toml", r"Rs >= Rc \(Vs - V0\)/Vmax - Rc - r = ([\d.]+) x ([\d.]+)/([\d.]+) - ([\d.]+) # = ([\d.]+) ohm "
     r"-> ([\d.]+) ohm \(E24\): ([\d.]+) V at the coil at level 1, ([\d.]+) W in # the resistor \(a (\d+) W part\)",
     lambda c: _series(c)),
    ("hw/sensor.toml", r"shared by the series resistor and the coil: ([\d.]+) V for ([\d.]+) V, an # L298N, ([\d.]+) \+ "
     r"([\d.]+) ohm, so the paper's 3 V is level ([\d.]+) and every level # is within max_coil_voltage; with "
     r"series_resistance = 0: ([\d.]+) V, level # ([\d.]+), levels above ([\d.]+) refused",
     lambda c: _full_scale(c)),
    ("hw/sensor.toml", r"The wound coil \((\d+) turns, ([\d.]+) ohm\)", lambda c: [c.d.coil.turns, c.d.coil.resistance]),
    # assembly: the mould and the adapter
    ("docs/assembly.md", r"puts the rod's lower end (\d+) mm under the membrane", lambda c: [c.d.rod_below_membrane]),
    ("docs/assembly.md", r"\(([\d.]+) g/cm\^3\) is denser than Ecoflex 00-30 \(([\d.]+) g/cm\^3\)",
     lambda c: [c.d.mechanics.rod_density, c.d.membrane.density]),
    ("docs/assembly.md", r"`mold.rod_slack` = ([\d.]+) mm above the tip of a nominal (\d+) mm rod. A rod cut up to ([\d.]+) mm long",
     lambda c: [c.d.mold.rod_slack, c.d.whiskers.rod_length, c.d.mold.rod_slack]),
    ("docs/assembly.md", r"held by the ring's (\d+) mm socket", lambda c: [c.d.ring.hole_depth]),
    ("docs/assembly.md", r"`mold.draft_deg` = (\d+) deg", lambda c: [c.d.mold.draft_deg]),
    ("docs/assembly.md", r"membrane's top is therefore ([\d.]+) mm wider than nominal \(\(thickness/2\) tan (\d+) deg\), and its bottom is ([\d.]+) mm narrower",
     lambda c: [c.d.membrane.thickness / 2 * math.tan(math.radians(c.d.mold.draft_deg)), c.d.mold.draft_deg,
                c.d.membrane.thickness / 2 * math.tan(math.radians(c.d.mold.draft_deg))]),
    ("docs/assembly.md", r"inside the mount seat's ([\d.]+) mm `print.clearance`", lambda c: [c.d.print.clearance]),
    ("docs/assembly.md", r"they lie on a ([\d.]+) mm circle", lambda c: [flanges.flange("iso9409_31_5_4_m5").pitch_diameter]),
    ("docs/assembly.md", r"from below: (\d+) M(\d) screws", lambda c: [c.d.mount.mounting_hole_count, 3]),
    ("docs/assembly.md", r"drive the (\d+) M(\d) coupling screws", lambda c: [c.d.adapter.coupling_count, 3]),    # heat: the thermal network's first limit and safe duty at the grasp voltage, the paper's protocol
    ("README.md", r"the first thermal limit is the resin bobbin at the winding \((\d+) C\) after \*\*([\d.]+) s\*\*, "
     r"and the safe continuous duty cycle is \*\*([\d.]+) %\*\*",
     lambda c: _thermal_summary(c.d)),
    ("README.md", r"the guard steps in \*\*([\d.]+) s\*\* after switching on. Holding at level \*\*([\d.]+)\*\* after "
     r"the whiskers close \((\d+) % of the 3 V grasp level, ([\d.]+)\)",
     lambda c: _protocol_numbers(c.d)),
]


def _thermal_summary(d):
    from whisker.coil.thermal_network import summary

    s = summary(d, d.actuation.voltage)
    return [s["limit_C"], s["time_to_first_limit_s"], 100 * s["safe_duty"]]


def _protocol_numbers(d):
    from whisker.drive.guard import volts_to_levels
    from whisker.drive.thermal_protocol import fit_hold_level, run_protocol

    lvl = float(volts_to_levels(d, [d.actuation.voltage])[0])
    hold = fit_hold_level(d, lvl)
    return [run_protocol(d, lvl).first_reduced_s, hold, 100 * hold / lvl, lvl]

#: Numbers with "mm" in FILES that are not CAD dimensions of the default design, and why.
EXEMPT = [
    (r"0\.5 mm steps", "a sizing rule's step (whisker.design.sizing)"),
    (r"default 2\.5 mm mesh", "the membrane model's mesh (benchmarks/results/membrane.md; tests/test_membrane.py)"),
    (r"6 whiskers on a 10 mm ring", "a command-line example"),
    (r"--set whiskers\.ring_radius=10", "a command-line example"),
    (r"about 20 px, or 1\.9 mm, at the markers", "measured in the authors' frame"),
    (r"coil clearance over full deflection = 0 mm, needs >= 0\.2: coils 13 and 14 overlap by 12 mm\^3",
     "an example refusal of another design"),
    (r"ring radii 4\.\.25 mm in 1 mm", "the sweep's range (docs/sweep.md)"),
    (r"first 1 mm step", "the sweep's step"),
    (r"radii 4, 10, 16, 22 mm", "make docs' reduced sweep grid (mk/docs.mk DOCS_SWEEP_RADII)"),
    (r"prusa_mk3s_pla_0\.2mm\.ini", "a file name"),
    (r"0\.011 mm RMS", "a simulator measurement (make sim-camera)"),
    (r"~0\.3-0\.4 mm", "a simulator measurement"),
    (r"with a 120 x 120 mm bed and 50 mm height", "a made-up small printer for the refusal example"),
    (r"within 5 mm of its edge", "the overhang check's setting (printcheck.MAX_BRIDGE_MM / 2)"),
    (r"The 10 mm bridge limit", "the overhang check's setting (printcheck.MAX_BRIDGE_MM)"),
    (r"\| \d+ whiskers, \d+ mm ring( \(default\))? \|", "slicer results of other designs (make check-print)"),
    (r"0\.3 mm layers", "the coarse slicer setting (printcheck.COARSE_ARGS)"),
    (r"radially out [\d.]+ mm \(neck_to_pocket\)", "generated from the sequence (tests/test_assembly_images.py)"),
    (r"whisker hw bom --set whiskers.count=6", "a command-line example"),
    (r"0\.1 mm enamelled copper wire spool", "a vendor listing"),
    (r"\| mount \| [\d.]+ g \(", "benchmark results (benchmarks/results/bom.md)"),
    (r"6\.00 m|4\.71 m|3\.25 m", "benchmark results"),
    (r"4 x 4 mm former", "the paper's coil (docs/coil.md)"),
    (r"1 mm x 500 mm carbon rods", "a vendor listing"),
    (r"(\d+) x ([\d.]+) mm \(3/16 x 1/16 in, N42\)", "the part's catalogue size"),
    (r"AWG 38 = 0\.1007 mm", "the wire gauge's definition (ASTM B258)"),
    (r"M12 x 0\.5", "the lens thread's designation"),
    (r"M3 x 10", "checked above (ISO 4762 designation)"),
    (r"A 5 mm magnet is not a K&J D31", "an example of another design"),
    (r"600 turns of 0\.101 mm wire d", "the paper's coil (docs/coil.md)"),
]


@pytest.fixture(scope="module")
def ctx(default_build):
    return Ctx(load_manifest(default_build))


def _agrees(doc: str, want, slack: float = 0.0) -> bool:
    if isinstance(want, str):
        return doc == want
    if doc.lower() in WORDS:
        return WORDS[doc.lower()] == want
    decimals = len(doc.split(".")[1]) if "." in doc else 0
    return abs(float(doc) - float(want)) <= 0.5 * 10 ** -decimals + slack + 1e-9


@pytest.mark.parametrize("i", range(len(CHECKS)), ids=[f"{f}:{r[:40]}" for f, r, _ in CHECKS])
def test_stated_numbers_equal_the_design(ctx, i):
    name, pattern, expected = CHECKS[i]
    found = re.findall(pattern, _text(name))
    assert found, f"{name}: statement not found (reworded? update tests/test_docs_numbers.py): {pattern}"
    want = list(expected(ctx))
    for groups in found:
        groups = [groups] if isinstance(groups, str) else list(groups)
        assert len(groups) == len(want), pattern
        bad = [(g, w) for g, w in zip(groups, want) if not _agrees(g, w)]
        assert not bad, f"{name}: {pattern} says {groups}, the design gives {[round(w, 4) for w in want]}"


def test_print_size_table_matches_the_manifest(ctx):
    """docs/printing.md's size column, row by row, against the print bounding box of the CAD
    (the slicer measures the STL, whose chords on a round rim lie up to 0.1 mm inside it); every
    printed sensor part has a row."""
    rows = re.findall(r"\| (\w+)(?: \(printed upside down\)| \(once\))? \| ([\d.]+) x ([\d.]+) x ([\d.]+) \|",
                      _text("docs/printing.md"))
    seen = set()
    for part, *dims in rows:
        assert part in ctx.m["parts"], part
        size = ctx.size(part)
        assert all(_agrees(g, w, slack=0.1) for g, w in zip(dims, size)), f"{part}: docs {dims}, manifest {size}"
        seen.add(part)
    from whisker.part_measures import PRINTED_PARTS
    assert set(PRINTED_PARTS) <= seen


def test_readme_parts_table_lists_every_part(ctx):
    """Part counts: every part `make stl` exports has a row in the README's parts table, printed
    ("yes"; the bobbin "resin") or not, and the table names no other part."""
    rows = dict(re.findall(r"\| `(\w+)` \| (yes|no|resin) \|", _text("README.md")))
    parts = {n: p for n, p in ctx.m["parts"].items() if "description" in p}
    reference = {"membrane", "rod", "coil", "magnet"}
    assert "| `membrane`, `rod`, `coil`, `magnet` | no |" in _text("README.md")
    assert set(rows) == set(parts) - reference
    for name, state in rows.items():
        assert (state == "yes") == bool(parts[name]["printable"]), name


def test_every_mm_number_in_the_cad_docs_is_checked_or_exempt():
    loose = []
    for name in FILES:
        text = _text(name)
        spans = [m.span() for p in [r for f, r, _ in CHECKS if f == name] + [r for r, _ in EXEMPT]
                 for m in re.finditer(p, text)]
        for m in re.finditer(r"(?<![\w.])\d+(?:\.\d+)?(?= ?mm\b)", text):
            if not any(a <= m.start() < b for a, b in spans):
                loose.append(f"{name}: ...{text[max(0, m.start() - 50):m.end() + 10]}...")
    assert not loose, "numbers neither checked nor exempt:\n" + "\n".join(loose)


def test_checked_statements_still_catch_a_wrong_number(ctx):
    """A doc that says 53.0 mm for the mount's height (the number before the camera profiles
    moved it) is caught."""
    _, pattern, expected = CHECKS[[i for i, c in enumerate(CHECKS) if "fits printer" in c[1]][0]]
    wrong = "mount: fits printer = 53 mm, needs <= bed 120 x 120 x 50: part is 44.0 x 44.0 x 53.0 mm"
    groups = re.findall(pattern, wrong)[0]
    assert not all(_agrees(g, w) for g, w in zip(groups, expected(ctx)))
