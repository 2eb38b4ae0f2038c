"""Fabrication outputs of the routed HAT, by kicad-cli 9: Gerbers, Excellon drill, JLCPCB BOM and CPL,
top and bottom renders.

Gerber and drill files are made stable: kicad-cli writes the creation date (X2 ``TF.CreationDate`` and
the ``G04 Created by KiCad ... date`` / ``; DRILL file ... date`` comments); those lines are dropped, so
a second run on the same board gives the same bytes (tests/test_hat_board.py checks it).
"""

from __future__ import annotations

import csv
import io
import re
import subprocess
from pathlib import Path

from .kicad import BoardFailed, kicad_cli

GERBER_LAYERS = ("F.Cu", "In1.Cu", "In2.Cu", "B.Cu", "F.Paste", "B.Paste", "F.Silkscreen", "B.Silkscreen",
                 "F.Mask", "B.Mask", "Edge.Cuts")
#: a line carrying a timestamp (X2 CreationDate attribute or comment, "Created by KiCad ... date", drill header)
_VOLATILE = re.compile(r"^.*(\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}|CreationDate).*\n", re.M)


def _cli(*args: str) -> None:
    proc = subprocess.run([kicad_cli(), *args], capture_output=True, text=True, timeout=900)
    if proc.returncode != 0:
        raise BoardFailed(f"kicad-cli {' '.join(args[:3])} failed: {proc.stderr.strip()[-200:]}")


def stabilise(path: Path) -> None:
    """Drop the date lines kicad-cli writes (everything else byte for byte)."""
    text = path.read_text()
    if path.suffix == ".gbrjob":   # JSON: drop the key, keep the syntax (a dropped line leaves a dangling comma)
        import json

        job = json.loads(text)
        job.get("Header", {}).pop("CreationDate", None)
        path.write_text(json.dumps(job, indent=2) + "\n")
        return
    path.write_text(_VOLATILE.sub("", text))


def gerbers(board: Path, out: Path) -> list[str]:
    out.mkdir(parents=True, exist_ok=True)
    _cli("pcb", "export", "gerbers", "--layers", ",".join(GERBER_LAYERS), "--no-protel-ext", "--no-x2",
         "--subtract-soldermask", "-o", str(out) + "/", str(board))
    _cli("pcb", "export", "drill", "--format", "excellon", "--excellon-separate-th", "--generate-map",
         "--map-format", "gerberx2", "-o", str(out) + "/", str(board))
    names = sorted(p.name for p in out.iterdir() if p.is_file())
    for n in names:
        stabilise(out / n)
    return names


def position_rows(board: Path, tmp: Path) -> list[dict]:
    pos = tmp / "pos.csv"
    _cli("pcb", "export", "pos", "--format", "csv", "--units", "mm", "--side", "both", "--exclude-dnp",
         "-o", str(pos), str(board))
    return list(csv.DictReader(io.StringIO(pos.read_text())))


def jlc_cpl(rows: list[dict]) -> str:
    """JLCPCB pick-and-place: Designator, Mid X, Mid Y, Layer, Rotation (mm, deg)."""
    buf = io.StringIO()
    wr = csv.writer(buf, lineterminator="\n")
    wr.writerow(["Designator", "Mid X", "Mid Y", "Layer", "Rotation"])
    for r in sorted(rows, key=lambda r: _ref_key(r["Ref"])):
        wr.writerow([r["Ref"], f"{float(r['PosX']):.4f}mm", f"{float(r['PosY']):.4f}mm",
                     "Top" if r["Side"].lower().startswith("top") else "Bottom", f"{float(r['Rot']):g}"])
    return buf.getvalue()


def jlc_bom(parts: list[dict]) -> str:
    """JLCPCB BOM: Comment, Designator, Footprint, MPN, one line per distinct part (mounting holes left out)."""
    groups: dict = {}
    for p in parts:
        if p.get("exclude_from_bom"):
            continue
        key = (p["value"], p["footprint"].split(":", 1)[1], p.get("fields", {}).get("MPN", ""))
        groups.setdefault(key, []).append(p["ref"])
    buf = io.StringIO()
    wr = csv.writer(buf, lineterminator="\n")
    wr.writerow(["Comment", "Designator", "Footprint", "MPN", "Quantity"])
    for (value, fp, mpn), refs in sorted(groups.items(), key=lambda kv: _ref_key(sorted(kv[1], key=_ref_key)[0])):
        refs = sorted(refs, key=_ref_key)
        wr.writerow([value, ",".join(refs), fp, mpn, len(refs)])
    return buf.getvalue()


def render(board: Path, out_png: Path, side: str) -> None:
    _cli("pcb", "render", "--side", side, "--width", "1300", "--height", "1130", "--quality", "basic",
         "-o", str(out_png), str(board))


def _ref_key(ref: str):
    head = ref.rstrip("0123456789")
    return head, int(ref[len(head):] or 0)
