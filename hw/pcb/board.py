"""The HAT from the design to fabrication files, in one folder, atomically (``make pcb`` ->
hw/pcb/generated/hat/).

Without KiCad the circuit, its ERC and the placement spec are still written (``route=False``), and
:func:`build_hat` raises :class:`whisker.pcb.kicad.KicadMissing` with one line naming what to install
before touching the output folder. A routed board that fails the DRC gate (any error or unconnected
item) or that has a via on an SMD pad (whisker.pcb.copper.vias_on_smd_pads) raises :class:`BoardFailed`;
the previous files stay.

Files: ``hat.net`` (SKiDL netlist), ``hat_erc.txt``, ``placement.json`` (the spec pcbnew builds from),
``hat.kicad_pcb`` (routed), ``drc.json`` (counts), ``gerbers/`` (Gerbers + Excellon, date lines
dropped), ``bom_jlcpcb.csv``, ``cpl_jlcpcb.csv``, ``hat_top.png``, ``hat_bottom.png``, ``schematic/``
(KiCad schematic sheets, their SVGs and a PDF, whisker.pcb.schematic; with the routed board), and
``hat_summary.json`` written last (with the sha256 of every Gerber and drill file).
"""

from __future__ import annotations

import hashlib
import json
import shutil
import tempfile
from pathlib import Path

from whisker.design import Design, apply_overrides, design_from_dict
from whisker.files import atomic_write_json, atomic_write_text, publish, staging_dir

from . import fab, hat, kicad, layout, schematic
from .build import erc_text
from .netlist import netlist_text


class HatErcFailed(RuntimeError):
    pass


def hat_design(design: Design) -> Design:
    """The design with ``driver.type = "HAT"``: the board is generated whatever the design drives with."""
    if design.driver.type == "HAT":
        return design
    return design_from_dict(apply_overrides(design.to_dict(), ['driver.type="HAT"']))


def prepare(design: Design):
    """(circuit, ERC report, placement spec) of the HAT; no KiCad needed. HatError on bad input."""
    d = hat_design(design)
    circuit = hat.build_circuit(d)
    report = hat.erc(circuit)
    if not report.ok:
        first = next((m for m in report.messages if m.startswith("ERROR")), "")
        raise HatErcFailed(f"HAT ERC found {report.errors} error(s): {first}")
    return circuit, report, layout.place(circuit)


#: the boards kept under hw/pcb/generated/ and the design overrides they are made from: ``make pcb`` (the
#: default design, all files) and ``make hat-sizes`` (6 and 12 coils: summary, DRC report, top render;
#: 12 coils need the PCA9685s, moved above the INA3221s' 0x40-0x43)
SIZES = {"hat": (), "hat6": ("whiskers.count=6",),
         "hat12": ("whiskers.count=12", 'wiring.expander="pca9685"', "wiring.pca9685_address=0x44")}

#: the code that turns a placement spec into the routed board and its fabrication files
BOARD_CODE = ("kicad.py", "kicad_job.py", "router.py", "maze.py", "fab.py")


def input_digest(spec: dict) -> str:
    """sha256 of what the routed board depends on: the placement spec and the code that routes and
    exports it. ``hat_summary.json`` keeps it, so a test sees a stale committed board without routing."""
    h = hashlib.sha256(json.dumps(spec, sort_keys=True).encode())
    for name in BOARD_CODE:
        h.update(Path(__file__).with_name(name).read_bytes())
    return h.hexdigest()


def build_hat(design: Design, out: str | Path, route: bool = True, log=print) -> dict:
    out = Path(out)
    circuit, report, spec = prepare(design)
    if route:
        kicad.require_kicad()
    summary = {"whiskers": design.whiskers.count, "parts": len(circuit.parts), "nets": len(circuit.nets),
               "erc_errors": report.errors, "erc_warnings": report.warnings, "rules": spec["rules"],
               "bridge": circuit.design.driver.bridge, "monitor": circuit.design.driver.current_monitor}
    with staging_dir(out) as tmp:
        names = ["hat.net", "hat_erc.txt", "placement.json"]
        atomic_write_text(tmp / "hat.net", netlist_text(circuit))
        atomic_write_text(tmp / "hat_erc.txt", erc_text(report))
        atomic_write_text(tmp / "placement.json", json.dumps(spec, indent=1, sort_keys=True) + "\n")
        if route:
            work = Path(tempfile.mkdtemp(prefix="whisker-hat-"))
            try:
                log("pcb: schematic (schematizer, kicad-cli sch export svg, sch erc)")
                summary["schematic"] = schematic.draw(circuit, tmp / "schematic")
                names += [f"schematic/{n}" for n in summary["schematic"]["files"]]
                res = kicad.route_board(spec, work, log=log)
                drc = res["drc"]
                summary["drc"] = drc
                summary["input_digest"] = input_digest(spec)
                summary["routed"] = {k: res[k] for k in ("fanout_vias", "routed_tracks", "routed_vias")}
                summary["vias_on_smd_pads"] = len(res["vias_on_smd_pads"])
                if drc["errors"] or drc["unconnected"]:
                    raise kicad.BoardFailed(
                        f"DRC: {drc['errors']} error(s) {drc['error_types']}, {drc['unconnected']} unconnected "
                        f"({drc['first_error'] or drc['first_unconnected']}); work files in {work}")
                if res["vias_on_smd_pads"]:
                    raise kicad.BoardFailed(f"{len(res['vias_on_smd_pads'])} via(s) on SMD pads (via-in-pad): "
                                            f"{res['vias_on_smd_pads'][0]}; work files in {work}")
                shutil.copy(res["board"], tmp / "hat.kicad_pcb")
                atomic_write_json(tmp / "drc.json", drc)
                log("pcb: gerbers, drill, BOM, CPL, renders")
                g = fab.gerbers(tmp / "hat.kicad_pcb", tmp / "gerbers")
                rows = fab.position_rows(tmp / "hat.kicad_pcb", work)
                atomic_write_text(tmp / "cpl_jlcpcb.csv", fab.jlc_cpl(rows))
                atomic_write_text(tmp / "bom_jlcpcb.csv", fab.jlc_bom(spec["parts"]))
                fab.render(tmp / "hat.kicad_pcb", tmp / "hat_top.png", "top")
                fab.render(tmp / "hat.kicad_pcb", tmp / "hat_bottom.png", "bottom")
                names += ["hat.kicad_pcb", "drc.json", *[f"gerbers/{n}" for n in g], "cpl_jlcpcb.csv",
                          "bom_jlcpcb.csv", "hat_top.png", "hat_bottom.png"]
                summary["gerbers"] = g
                # the files' sha256: a later run (or a board kept only as its summary) is compared byte for byte
                summary["gerbers_sha256"] = {n: hashlib.sha256((tmp / "gerbers" / n).read_bytes()).hexdigest()
                                             for n in g}
            finally:
                if not kicad.KEEP_WORK:
                    shutil.rmtree(work, ignore_errors=True)
        elif kicad.kicad_status()[0]:
            # not routed, but KiCad is here: the placed board with its planes filled (GND/VM complete,
            # the signal nets left to route) and its renders, for the docs
            work = Path(tempfile.mkdtemp(prefix="whisker-hat-"))
            try:
                (work / "spec.json").write_text(json.dumps(spec))
                first = kicad.run_job("build", work, spec=work / "spec.json", board=work / "placed.kicad_pcb", dsn="")
                tracks, vias = kicad.fanout(spec, first["pads"])
                (work / "spec.json").write_text(json.dumps({**spec, "tracks": tracks, "vias": vias}))
                kicad.run_job("build", work, spec=work / "spec.json", board=work / "unrouted.kicad_pcb", dsn="")
                kicad.run_job("fill", work, board=work / "unrouted.kicad_pcb", out=tmp / "hat_placed.kicad_pcb")
                drc = kicad.drc(tmp / "hat_placed.kicad_pcb", work / "drc.json")
                summary["placed_drc"] = drc
                fab.render(tmp / "hat_placed.kicad_pcb", tmp / "hat_top.png", "top")
                fab.render(tmp / "hat_placed.kicad_pcb", tmp / "hat_bottom.png", "bottom")
                names += ["hat_placed.kicad_pcb", "hat_top.png", "hat_bottom.png"]
            finally:
                shutil.rmtree(work, ignore_errors=True)
        atomic_write_json(tmp / "hat_summary.json", summary)
        # sheets of a previous build with more bridges must not outlive it
        stale = [f"schematic/{p.name}" for p in (out / "schematic").glob("*")] if route else []
        publish(tmp, out, [*names, "hat_summary.json"], stale=stale)
    return summary
