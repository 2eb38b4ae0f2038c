"""The HAT's schematic drawing, headless: SKiDL circuit -> KiCad 9 ``.kicad_sch`` -> SVG sheets.

SKiDL writes a netlist, not a drawing. SKiDL 3's ``generate_schematic`` hands a tool-neutral netlist
to the ``schematizer`` package, which writes KiCad 6..10 schematics; KiCad 9's ``kicad-cli sch
export svg`` then plots them. Three things make that work for whisker.pcb.hat:

- the HAT's parts are defined in code (pad numbers only, no symbol graphics), so each one is drawn
  with the KiCad 9 library symbol of the same pinout (:data:`SYMBOLS`; tests/test_hat.py checks the
  DRV8833/INA3221/PCA9685 pin numbers against those symbols) and wired pin number by pin number;
- schematizer 0.2.0's placed-and-routed mode did not finish the flat ~80-part HAT in 15 minutes (2
  cores), on the block sheets below it raises RoutingFailure after 2 minutes, and with ``auto_stub``
  it finishes (14 s, same connectivity) but overlaps parts (coil connectors over the DRV8833's
  pins), so its labels mode draws it: every pin gets a short stub ending in a power symbol, a net label
  (net on one sheet) or a global label (net on several), and KiCad joins pins by label name.
  Connectivity is exact by construction, and it is checked (:func:`check_connectivity`): the
  netlist KiCad exports from the drawing must join exactly the pins the SKiDL circuit joins;
- one sheet per functional block (``Hat.info[ref]["block"]``): the Pi header with the ID EEPROM and
  the LED connector, the supply, one sheet per DRV8833 with its two coil connectors, sense resistors
  and capacitors, the current monitors, the PWM expander.

SKiDL's ``net.drive = POWER`` becomes a KiCad ``PWR_FLAG`` symbol, and ``kicad-cli sch erc`` must
find 0 errors (:func:`kicad_erc`).

Reproducible: schematizer seeds every UUID from names and coordinates; the only volatile text, the
title-block date in the ``.kicad_sch``, the plot date in each SVG's ``<title>`` and the PDF's
creation date, is dropped or fixed in
:func:`draw`, and kicad-cli runs with a private configuration folder (:func:`_run`). Files (into
``schematic/`` of the HAT folder): ``hat.kicad_sch`` (root sheet, opens in KiCad's schematic editor),
``hat_<block>.kicad_sch`` per block, ``hat-<block>.svg`` per block sheet, cut to its drawing
(:func:`crop_svg`), and ``hat.pdf`` (every sheet with its title block, for print).
"""

from __future__ import annotations

import os
import re
import subprocess
import tempfile
from pathlib import Path

from .hat import Hat
from .kicad import BoardFailed, KicadMissing, kicad_cli

#: KiCad 9 symbol libraries (Debian's kicad-symbols; KICAD9_SYMBOL_DIR overrides, as for SKiDL).
SYMBOL_DIR = Path(os.environ.get("KICAD9_SYMBOL_DIR", "/usr/share/kicad/symbols"))

#: part kind (whisker.pcb.hat) -> (KiCad library, symbol) with the same pin numbers. The P-FET is
#: drawn with IRF7404's symbol (SO-8, pins 1-3 S, 4 G, 5-8 D: the AO4407A's pinout), the CAT24C32
#: EEPROM with 24LC32's (A0-A2, VSS, SDA, SCL, WP, VCC on pins 1-8), the Pi header as the generic
#: 2x20 odd/even connector (pin n = header pin n).
SYMBOLS = {
    "bridge": ("Driver_Motor", "DRV8833PWP"),
    "monitor": ("Power_Management", "INA3221"),
    "expander": ("Driver_LED", "PCA9685PW"),
    "eeprom": ("Memory_EEPROM", "24LC32"),
    "header": ("Connector_Generic", "Conn_02x20_Odd_Even"),
    "fuse": ("Device", "Fuse"),
    "pfet": ("Transistor_FET", "IRF7404"),
    "resistor": ("Device", "R"),
    "capacitor": ("Device", "C"),
    "jumper": ("Jumper", "SolderJumper_2_Open"),
    "connector": ("Connector_Generic", "Conn_01x02"),
}
#: parts drawn with another symbol than their kind's: the polarised bulk capacitor, the screw terminal
SYMBOL_BY_REF = {"C100": ("Device", "C_Polarized"), "J2": ("Connector", "Screw_Terminal_01x02")}
#: block -> sheet title, in sheet order
BLOCK_TITLES = {"pi": "Raspberry Pi header, HAT ID EEPROM, LED strip connector",
                "supply": "supply terminal, fuse, reverse-polarity P-FET, bulk capacitor",
                "monitors": "coil current monitors (INA3221)", "expander": "PWM expanders (PCA9685)"}
TOP = "hat"
#: the date schematizer writes into the title block, and kicad-cli into each SVG's <title>
_SCH_DATE = re.compile(r'\(date "[^"]*"\)')
_SVG_DATE = re.compile(r"(<title>SVG Image created as \S+) date [0-9/: ]+(</title>)")
_PDF_DATE = re.compile(rb"(/CreationDate \(D:)\d{14}")
FIXED_PDF_DATE = b"20000101000000"


class SchematicFailed(BoardFailed):
    """The schematic could not be drawn, plotted or does not match the circuit (one line)."""


def symbol_of(ref: str, kind: str) -> tuple[str, str]:
    return SYMBOL_BY_REF.get(ref) or SYMBOLS[kind]


def block_title(block: str) -> str:
    if block.startswith("bridge"):
        return f"H-bridge {block[6:]} (DRV8833) and its two coils"
    return BLOCK_TITLES.get(block, block)


def schematic_circuit(hat: Hat):
    """A SKiDL circuit with the HAT's parts, refs, values, footprints and connections, each part a KiCad 9
    library symbol, grouped into one SKiDL Group (one sheet) per block."""
    from .netlist import _fast_traces, _skidl

    sk = _skidl()
    if not (SYMBOL_DIR / "Device.kicad_sym").exists():
        raise KicadMissing(f"KiCad 9's symbol libraries are needed for the schematic and are not in {SYMBOL_DIR}: "
                           "run scripts/system-deps (Debian: apt-get install -t bookworm-backports kicad-symbols)")
    if str(SYMBOL_DIR) not in sk.lib_search_paths[sk.KICAD9]:
        sk.lib_search_paths[sk.KICAD9].append(str(SYMBOL_DIR))
    ckt = sk.Circuit()
    ckt.no_files = True
    ckt.track_src = False
    new, flags = {}, []
    blocks: dict[str, list[str]] = {}
    for ref in hat.parts:
        blocks.setdefault(hat.info[ref]["block"], []).append(ref)
    with _fast_traces():
        for block in sorted(blocks, key=_block_key):
            with sk.Group(block, tag=block, circuit=ckt):
                for ref in sorted(blocks[block], key=_ref_key):
                    info = hat.info[ref]
                    lib, name = symbol_of(ref, info["kind"])
                    new[ref] = sk.Part(lib, name, tool=sk.KICAD9, circuit=ckt, ref=ref, value=info["value"],
                                       footprint=info["footprint"])
        for name in sorted(hat.nets):
            net = sk.Net(name, circuit=ckt)
            for pin in hat.nets[name].pins:
                net += _pin(new[pin.part.ref], pin.num)
            src = hat.nets[name]
            if src.drive == sk.POWER and src.pins:
                # SKiDL's "this net is powered" (net.drive = POWER) is KiCad's PWR_FLAG symbol: on the
                # sheet of the net's first part, so KiCad's ERC knows the same
                first = min(src.pins, key=lambda p: _ref_key(p.part.ref))
                with sk.Group(hat.info[first.part.ref]["block"], tag=hat.info[first.part.ref]["block"],
                              circuit=ckt):
                    flag = sk.Part("power", "PWR_FLAG", tool=sk.KICAD9, circuit=ckt, ref=f"#FLG{len(flags) + 1:02d}")
                flags.append(flag)
                net += _pin(flag, 1)
        for pin in hat.circuit.NC.pins:
            ckt.NC += _pin(new[pin.part.ref], pin.num)
    return ckt


def _pin(part, num):
    """The pin numbered `num` of a library part (exactly that number, not a name or pattern match)."""
    found = [p for p in part.pins if str(p.num) == str(num)]
    if len(found) != 1:
        raise SchematicFailed(f"{part.ref}: symbol {part.name} has {len(found)} pins numbered {num}")
    return found[0]


def _ref_key(ref: str):
    head = ref.rstrip("0123456789")
    return head, int(ref[len(head):] or 0)


def _block_key(block: str):
    order = ["pi", "supply", "bridge", "monitors", "expander"]
    head = block.rstrip("0123456789")
    return order.index(head) if head in order else len(order), int(block[len(head):] or 0)


def draw(hat: Hat, out: Path) -> dict:
    """Write the schematic sheets (.kicad_sch), their SVG plots and the PDF into `out`; returns
    {"files": names relative to `out`, sorted; "kicad_erc": counts}. SchematicFailed when a step fails,
    the drawing's connectivity differs from the circuit's, or KiCad's ERC finds an error in it."""
    import schematizer
    from skidl.schematic_netlist import build_generic_netlist

    ckt = schematic_circuit(hat)
    ckt.merge_nets()
    title = f"whisker HAT, {hat.design.whiskers.count} coils"
    doc = build_generic_netlist(ckt, title=title, top_name=TOP)
    out.mkdir(parents=True, exist_ok=True)
    try:
        schematizer.render(doc, tool="kicad9", filepath=str(out), top_name=TOP, title=title, mode="labels")
    except Exception as err:  # schematizer's own errors: one line
        raise SchematicFailed(f"schematizer could not draw the HAT: {err}") from None
    sheets = sorted(out.glob("*.kicad_sch"))
    for sch in sheets:
        text = _SCH_DATE.sub('(date "")', sch.read_text())
        block = sch.stem[len(TOP) + 1:]
        if block:   # the title block names what the sheet holds
            text = text.replace(f'(title "{title} - {block}")', f'(title "{title}: {block_title(block)}")', 1)
        sch.write_text(text)
    _cli("sch", "export", "svg", "--exclude-drawing-sheet", "-o", str(out), str(out / f"{TOP}.kicad_sch"))
    (out / f"{TOP}.svg").unlink(missing_ok=True)   # the root sheet: only the block boxes, nothing to read
    for svg in out.glob("*.svg"):
        svg.write_text(crop_svg(_SVG_DATE.sub(r"\1\2", svg.read_text())))
    # all sheets with their title blocks in one PDF, for print; its one volatile field is the creation
    # date, set to a fixed one of the same length (the cross-reference offsets stay valid)
    pdf = out / f"{TOP}.pdf"
    _cli("sch", "export", "pdf", "-o", str(pdf), str(out / f"{TOP}.kicad_sch"))
    pdf.write_bytes(_PDF_DATE.sub(lambda m: m.group(1) + FIXED_PDF_DATE, pdf.read_bytes()))
    check_connectivity(hat, out / f"{TOP}.kicad_sch")
    erc = kicad_erc(out / f"{TOP}.kicad_sch")
    if erc["errors"]:
        raise SchematicFailed(f"kicad-cli sch erc: {erc['errors']} error(s) {erc['error_types']}: {erc['first_error']}")
    return {"files": sorted(p.name for p in out.iterdir() if p.suffix in (".kicad_sch", ".svg", ".pdf")),
            "kicad_erc": {k: erc[k] for k in ("errors", "warnings", "warning_types")}}


#: a coordinate pair of a KiCad SVG path ("x,y", mm) and the page size in the <svg> element
_XY = re.compile(r"(-?\d+\.\d+),(-?\d+\.\d+)")
_PAGE = re.compile(r'width="[0-9.]+mm" height="[0-9.]+mm" viewBox="[0-9. ]+"')


def crop_svg(text: str, pad_mm: float = 5.0) -> str:
    """The SVG cut to its drawing plus `pad_mm` (labels mode fills the top left of an A4/A3 page;
    kicad-cli has no fit-to-content option): the bounding box of every path point, as width, height and
    viewBox in mm."""
    pts = [(float(x), float(y)) for d in re.findall(r'd="([^"]*)"', text) for x, y in _XY.findall(d)]
    if not pts:
        return text
    x0, y0 = min(p[0] for p in pts) - pad_mm, min(p[1] for p in pts) - pad_mm
    x1, y1 = max(p[0] for p in pts) + pad_mm, max(p[1] for p in pts) + pad_mm
    x0, y0 = max(x0, 0.0), max(y0, 0.0)
    w, h = x1 - x0, y1 - y0
    return _PAGE.sub(f'width="{w:.4f}mm" height="{h:.4f}mm" viewBox="{x0:.4f} {y0:.4f} {w:.4f} {h:.4f}"', text, count=1)


def _run(args: list[str]) -> subprocess.CompletedProcess:
    """kicad-cli with a private, empty configuration folder. Its schematic commands set up KiCad's
    user configuration on their first run (a global fp-lib-table among it), which changes what later
    ``kicad-cli pcb drc`` runs report (lib_footprint_issues warnings); a private folder keeps the
    schematic steps from touching the user's KiCad setup and from depending on it (theme, fonts)."""
    with tempfile.TemporaryDirectory(prefix="whisker-kicad-config-") as cfg:
        env = {**os.environ, "KICAD_CONFIG_HOME": cfg}
        return subprocess.run([kicad_cli(), *args], capture_output=True, text=True, timeout=600, env=env)


def _cli(*args: str) -> str:
    proc = _run(list(args))
    if proc.returncode != 0:
        raise SchematicFailed(f"kicad-cli {' '.join(args[:3])} failed: {(proc.stderr or proc.stdout).strip()[-200:]}")
    return proc.stdout


def drawing_nets(sch: Path) -> dict[str, set[tuple[str, str]]]:
    """net name -> {(ref, pin)} of the netlist kicad-cli exports from schematic `sch` (power symbols,
    ``#PWR...``, left out; a sheet-local net's name keeps KiCad's ``/sheet/`` prefix)."""
    from kinparse import parse_netlist

    with tempfile.TemporaryDirectory(prefix="whisker-sch-") as tmp:
        net = Path(tmp) / "drawing.net"
        _cli("sch", "export", "netlist", "--format", "kicadsexpr", "-o", str(net), str(sch))
        nl = parse_netlist(net.read_text())
    out: dict[str, set[tuple[str, str]]] = {}
    for n in nl.nets:
        pins = {(str(p.ref), str(p.num)) for p in n.pins if not str(p.ref).startswith("#")}
        if pins:
            out[str(n.name)] = pins
    return out


def kicad_erc(sch: Path) -> dict:
    """``kicad-cli sch erc`` (all severities) on the drawing: counts and types. Its warnings are
    ``lib_symbol_issues`` (the symbols are embedded in the file; a headless KiCad has no symbol
    library table to compare them with) and ``pin_to_pin`` on DRV8833 VCP (bidirectional in KiCad's
    symbol) meeting its PWR_FLAG."""
    import json

    with tempfile.TemporaryDirectory(prefix="whisker-erc-") as tmp:
        rep = Path(tmp) / "erc.json"
        _run(["sch", "erc", "--severity-all", "--format", "json", "-o", str(rep), str(sch)])
        if not rep.exists():
            raise SchematicFailed(f"kicad-cli sch erc wrote no report for {sch.name}")
        viol = [v for sheet in json.loads(rep.read_text()).get("sheets", []) for v in sheet.get("violations", [])]
    errors = [v for v in viol if v.get("severity") == "error"]
    warnings = [v for v in viol if v.get("severity") == "warning"]
    return {"errors": len(errors), "warnings": len(warnings),
            "error_types": sorted({v.get("type", "?") for v in errors}),
            "warning_types": sorted({v.get("type", "?") for v in warnings}),
            "first_error": (errors[0].get("description", "") if errors else "")}


def check_connectivity(hat: Hat, sch: Path) -> None:
    """The drawing joins exactly the pins the circuit joins, under the same net names (KiCad's sheet
    prefix dropped); SchematicFailed names the first difference."""
    want = {name: {(p.part.ref, str(p.num)) for p in net.pins} for name, net in hat.nets.items()}
    want = {k: v for k, v in want.items() if v}
    got = {name.rsplit("/", 1)[-1]: pins for name, pins in drawing_nets(sch).items()}
    # KiCad names the net of each pin left open "unconnected-(REF-PIN-PadN)": those are the circuit's NC pins
    nc = {(p.part.ref, str(p.num)) for p in hat.circuit.NC.pins}
    open_pins = set().union(*[got.pop(k) for k in [k for k in got if k.startswith("unconnected-")]])
    if open_pins != nc:
        diff = sorted(open_pins ^ nc)
        raise SchematicFailed(f"schematic leaves {len(open_pins)} pins open, the circuit {len(nc)} (first "
                              f"difference: {diff[0]})")
    for name in sorted(set(want) | set(got)):
        if want.get(name) != got.get(name):
            raise SchematicFailed(f"schematic net {name!r} joins {sorted(got.get(name, ()))[:4]}, the circuit "
                                  f"{sorted(want.get(name, ()))[:4]}")
