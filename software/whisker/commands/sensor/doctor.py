"""`whisker doctor`: is this machine ready to run the sensor? One line per item, "ok" or what to do."""

from __future__ import annotations

import glob
import json
import os
import re
import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import click


@dataclass(frozen=True)
class Check:
    item: str
    ok: bool
    detail: str  # what was found when ok; what to do when not


def check_design(design_file, overrides):
    """(Check, Design or None): the design in use, validated."""
    from whisker.design import DEFAULT_DESIGN, DesignError, load_design

    path = Path(design_file) if design_file else DEFAULT_DESIGN
    try:
        design = load_design(design_file, overrides)
    except DesignError as err:
        return Check("design", False, f"{path}: {err} - fix the file or the --set value"), None
    return Check("design", True, f"{path} (digest {design.digest()}, {design.whiskers.count} whiskers at "
                                 f"{design.whiskers.ring_radius:g} mm)"), design


def check_extras() -> Check:
    """Which extras are installed; a missing one is not a fault (the Pi needs only the core)."""
    from whisker.extras import extras_status, install_command

    status = extras_status()
    have = [e for e, missing in status.items() if not missing and e != "all"]
    lack = [e for e, missing in status.items() if missing and e != "all"]
    detail = "core" + (" + " + ", ".join(have) if have else " only")
    if lack:
        detail += "; not installed: " + ", ".join(f"{e} ({install_command(e)})" for e in lack)
    return Check("extras", True, detail)


def check_kicad() -> Check:
    """KiCad 9 for the HAT's board steps (make pcb); not needed to run the sensor, so never a fault."""
    try:
        from whisker.pcb.kicad import kicad_status
    except ImportError as err:  # the hw extra (SKiDL) is missing: the board code is not importable
        return Check("kicad", True, f"board steps unavailable ({err}); the sensor does not need them")
    ok, line = kicad_status()
    return Check("kicad", True, line if ok else f"not installed (only `make pcb` needs it): {line}")


def _v4l2_indices() -> list[int]:
    """Indices of /dev/videoN nodes OpenCV can open for capture (codec nodes on a Pi cannot)."""
    import cv2

    found = []
    for dev in sorted(glob.glob("/dev/video*"), key=lambda p: int(re.sub(r"\D", "", p) or 0)):
        index = int(re.sub(r"\D", "", dev) or 0)
        cap = cv2.VideoCapture(index, cv2.CAP_V4L2)
        try:
            if cap.isOpened():
                found.append(index)
        finally:
            cap.release()
    return found


def check_camera() -> Check:
    sources = []
    try:
        from picamera2 import Picamera2
    except ImportError:
        picam = "Picamera2 not importable (Pi: sudo apt install python3-picamera2, venv with --system-site-packages)"
    else:
        try:
            cams = Picamera2.global_camera_info()
        except Exception as err:  # libcamera raises its own types; report, do not crash the report
            cams, picam = [], f"Picamera2 failed: {err}"
        else:
            picam = f"Picamera2: {len(cams)} camera(s)"
        sources += ["picamera"] * bool(cams)
    v4l2 = _v4l2_indices()
    sources += [str(i) for i in v4l2]
    found = f"{picam}; V4L2 indices: {', '.join(map(str, v4l2)) or 'none'}"
    if sources:
        return Check("camera", True, f"{found} -> whisker track --source {sources[0]}")
    return Check("camera", False, f"{found} - connect and enable a camera (docs/raspberry-pi.md), or use "
                                  "--source synthetic / a video file")


def check_gpio(design) -> Check:
    """gpiozero's pin factory (GPIOZERO_PIN_FACTORY or its default) and whether it opens every pin
    the design's wiring uses. Pins are opened and closed, never driven."""
    if design is None:
        return Check("gpio", False, "no valid design: fix the design first")
    from gpiozero import Device
    from gpiozero.exc import BadPinFactory

    from whisker.drive.pins import PinMapError, used_gpio

    try:
        used = used_gpio(design)
    except PinMapError as err:
        return Check("gpio", False, f"pin map: {err}")
    try:
        with warnings.catch_warnings():  # gpiozero warns once per pin library it cannot load
            warnings.simplefilter("ignore")
            Device.ensure_pin_factory()
        factory = Device.pin_factory
    except BadPinFactory as err:
        return Check("gpio", False, f"no pin factory ({err}): on a Raspberry Pi pip install "
                                    "'whisker-array[pi]' (or sudo apt install python3-lgpio); elsewhere "
                                    "use --backend mock or sim")
    name = type(factory).__name__
    if design.wiring.expander == "pca9685":  # the coils are on the expander; GPIO 2/3 belong to I2C
        bus = Path("/dev/i2c-1")
        if name != "MockFactory" and not bus.exists():
            return Check("gpio", False, f"{name}; the PCA9685 needs I2C: enable it (sudo raspi-config "
                                        "nonint do_i2c 0) and reboot")
        return Check("gpio", True, f"{name}; coils on PCA9685 board(s) on I2C1 ({bus} "
                                   f"{'present' if bus.exists() else 'absent, mock pins'})")
    failed = []
    for number, role in sorted(used.items()):
        try:
            pin = factory.pin(number)
            pin.function  # reads the line's state: fails when another process holds it
            pin.close()
        except Exception as err:  # noqa: BLE001 - lgpio/RPi.GPIO raise their own types (lgpio.error ...)
            failed.append(f"GPIO{number} ({role}): {err}")
    if failed:
        return Check("gpio", False, f"{name} cannot open " + "; ".join(failed)
                     + " - stop the process holding the pin, or add the user to the gpio group")
    numbers = ", ".join(map(str, sorted(used)))
    return Check("gpio", True, f"{name} opens all {len(used)} coil pins (GPIO {numbers})")


def check_state_file(design) -> Check:
    """The coil temperature state file the gpio backend reads and writes between runs."""
    from whisker.drive.actuation import default_state_file

    path = default_state_file("gpio")
    parent = next(p for p in (path, *path.parents) if p.exists())
    if not path.exists():
        if not os.access(parent, os.W_OK):
            return Check("coil state", False, f"{path}: {parent} is not writable - set XDG_CACHE_HOME "
                                              "to a writable folder")
        return Check("coil state", True, f"{path}: none yet (the coils start at ambient)")
    try:
        data = json.loads(path.read_text())
        age_s = time.time() - float(data["wall_time_s"])
        temps = [float(t) for t in data["temperatures_C"]]
    except (OSError, ValueError, KeyError, TypeError) as err:
        return Check("coil state", False, f"{path} is unreadable ({err}) - delete it: rm {path}")
    if not os.access(path, os.W_OK):
        return Check("coil state", False, f"{path} is not writable - fix its owner (it was written by another user?)")
    which = ("this design" if design is not None and data.get("digest") == design.digest()
             else "another design (ignored: coils start at ambient)")
    hottest = max(temps) if temps else float("nan")
    return Check("coil state", True, f"{path}: {which}, {age_s / 60:.0f} min old, hottest coil "
                                     f"{hottest:.1f} C then")


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--design", "design_file", type=click.Path(dir_okay=False), default=None,
              help="Design TOML file (default: hw/sensor.toml, the paper's sensor).")
@click.option("--set", "overrides", multiple=True, metavar="SECTION.KEY=VALUE", help="Override a design value.")
def cli(design_file, overrides):
    """Check this machine for the sensor: the design in use, the installed extras, the cameras
    (Picamera2, V4L2 indices), the GPIO pin factory and whether it opens the coil pins, the
    coil state file, and KiCad 9 for the HAT's board steps (informational). Each line says "ok" or what to do. Exit status 0 when every item is ok, 1 otherwise.

    GPIOZERO_PIN_FACTORY=mock checks the pin map on gpiozero's mock pins (no Raspberry Pi needed).
    """
    design_check, design = check_design(design_file, overrides)
    checks = [design_check, check_extras(), check_camera(), check_gpio(design), check_state_file(design),
              check_kicad()]
    width = max(len(c.item) for c in checks)
    for c in checks:
        click.echo(f"{'ok ' if c.ok else 'FIX'}  {c.item:<{width}}  {c.detail}")
    bad = sum(not c.ok for c in checks)
    click.echo(f"{len(checks) - bad}/{len(checks)} ok" + (f"; {bad} to fix" if bad else ""))
    sys.exit(1 if bad else 0)
