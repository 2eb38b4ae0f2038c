"""Write the driver-wiring outputs for a design into one folder, atomically.

Files: ``pinout.csv``, ``pinout.md``, ``wiring.png``, ``driver.net`` (KiCad netlist from SKiDL),
``erc.txt`` (SKiDL's ERC messages, counted) and ``summary.json`` (written last). ERC errors make
:func:`build` raise :class:`ErcFailed` after writing ``erc.txt`` to the staging folder only, so a
failed circuit never replaces a good output folder.
"""

from __future__ import annotations

from pathlib import Path

from whisker.design import Design
from whisker.files import atomic_write_json, atomic_write_text, publish, staging_dir
from whisker.drive.pins import supply_warnings

from . import diagram, netlist, pinout

FILES = ("pinout.csv", "pinout.md", "wiring.png", "driver.net", "erc.txt")


class ErcFailed(RuntimeError):
    """SKiDL's ERC found errors (one-line message with the count and the first error)."""

    def __init__(self, report: netlist.ErcReport):
        self.report = report
        first = next((m for m in report.messages if m.startswith("ERROR")), "")
        super().__init__(f"ERC found {report.errors} error(s): {first}")


def erc_text(report: netlist.ErcReport) -> str:
    lines = [f"errors: {report.errors}", f"warnings: {report.warnings}", *report.messages]
    return "\n".join(lines) + "\n"


def build(design: Design, out: str | Path, draw: bool = True) -> dict:
    """Build the circuit, run ERC, write every output into `out`; returns the summary.

    Raises PinMapError (too many coils for the chosen scheme) or ErcFailed (ERC errors).
    """
    out = Path(out)
    board = netlist.build_circuit(design)
    report = netlist.run_erc(board)
    if not report.ok:
        raise ErcFailed(report)
    summary = {"whiskers": design.whiskers.count,
               "expander": design.wiring.expander, "modules": sum(1 for r in board.parts if r[0] == "U"
                                                                  and int(r[1:]) < 100),
               "parts": len(board.parts), "nets": len(board.nets),
               "erc_errors": report.errors, "erc_warnings": report.warnings,
               "supply_warnings": supply_warnings(design),
               "files": [f for f in FILES if draw or f != "wiring.png"]}
    with staging_dir(out) as tmp:
        atomic_write_text(tmp / "pinout.csv", pinout.pinout_csv(design))
        atomic_write_text(tmp / "pinout.md", pinout.pinout_markdown(design))
        atomic_write_text(tmp / "driver.net", netlist.netlist_text(board))
        atomic_write_text(tmp / "erc.txt", erc_text(report))
        if draw:
            import matplotlib.pyplot as plt

            plt.close(diagram.draw(design, tmp / "wiring.png"))
        atomic_write_json(tmp / "summary.json", summary)
        publish(tmp, out, [*summary["files"], "summary.json"])
    return summary
