"""The coil-driver circuit as a SKiDL netlist, from the design's pin map.

Parts are defined here in code (``Part(tool=SKIDL, pins=[Pin(...)])``), so no KiCad symbol library
is needed. Pin electrical types follow the hardware so that SKiDL's ERC can catch wiring mistakes:

- Raspberry Pi 4B 40-pin header (J1): coil GPIO are OUTPUT, I2C pins BIDIR, GND pins POWER-IN, the
  3V3 pins POWER-OUT (they feed a PCA9685's logic), 5V pins POWER-OUT (pin 4 feeds the LED strip),
  every unused pin explicitly no-connect.
- L298N module (U1..Um): IN1..IN4 and ENA/ENB INPUT, OUT1..OUT4 OUTPUT, +12V (VS), +5V (logic)
  and GND POWER-IN. ENA/ENB sit on +5V (the module's jumpers), unused
  inputs of a half-used module are tied to GND, unused outputs are no-connect.
- coils (L1..LN): two PASSIVE pins across one channel's outputs; with a series resistor
  (``driver.series_resistance`` > 0, ``whisker.coil.driver.series_resistance_ohm``) R1..RN (PASSIVE) sit
  between OUT1/OUT3 (net COILi_OUTA) and coil pin A (net COILi_A).
- the coil supply (PS1): + and GND POWER-OUT (net "+<supply>V"); the 5 V LED strip (D1): POWER-IN,
  on the Pi's 5 V header pin (net "+5V_PI", ``whisker.drive.pins.LED_HEADER_PINS``), not the coil supply.
- a supply above the L298's 7 V logic maximum (the default 7.5 V) keeps each module's 5V-EN jumper:
  its regulator then drives the module's own +5V net (VLOGIC, ENA, ENB) instead of the supply; up to
  7 V the supply feeds VS and +5V with the jumper removed.
- PCA9685 boards (U101..) when wiring.expander = "pca9685": VCC/GND POWER-IN, SDA BIDIR, SCL and
  /OE INPUT, PWM0..15 OUTPUT, V+ (servo power) no-connect.

Two outputs on one net (e.g. two GPIO joined) is an ERC error; ``run_erc`` counts errors and
warnings, because SKiDL reports them but never fails.
"""

from __future__ import annotations

import contextlib
import io
import logging
import re
from dataclasses import dataclass, field

from whisker.design import Design
from whisker.drive.pins import (HEADER_PIN, HEADER_POWER, LED_HEADER_PINS, PCA9685_CHANNELS, CoilChannel,
                          expander_boards_needed, module_makes_own_logic_supply, modules_needed, pin_map)


def _skidl():
    """Import SKiDL quietly and without litter.

    At import SKiDL warns about KiCad library paths we never use and opens ``<script>.log`` /
    ``<script>.erc`` in the working directory. Import it inside a temporary directory, then stop
    its file output there (which deletes those files); ERC messages are collected by
    :func:`run_erc` instead.
    """
    import sys

    if "skidl" in sys.modules:
        return sys.modules["skidl"]
    import os
    import tempfile

    here = os.getcwd()
    with tempfile.TemporaryDirectory(prefix="skidl-") as tmp:
        os.chdir(tmp)
        try:
            with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
                import skidl

                from skidl.logger import stop_log_file_output

                stop_log_file_output()
        finally:
            os.chdir(here)
    return skidl


@contextlib.contextmanager
def _fast_traces():
    """SKiDL records where each part/net was made with ``inspect.stack()``, which reads the source
    of every frame: most of the build time, and seconds under a deep (pytest) stack. Within this
    block it gets the same (file, line) list from the frame objects, without reading sources."""
    import os
    import sys

    import skidl.circuit as skc

    skidl_dir = os.path.dirname(skc.__file__)

    def trace():
        frames, f = [], sys._getframe(1)
        while f is not None:
            name = f.f_code.co_filename
            if not name.startswith(skidl_dir):
                frames.append((os.path.abspath(name), str(f.f_lineno)))
            f = f.f_back
        return frames[::-1]

    original = skc.get_skidl_trace
    skc.get_skidl_trace = trace
    try:
        yield
    finally:
        skc.get_skidl_trace = original


@dataclass
class Board:
    """A built circuit: the SKiDL Circuit and handles to its parts and nets (for tests and drawing)."""

    design: Design
    circuit: object
    channels: list[CoilChannel]
    parts: dict[str, object] = field(default_factory=dict)
    nets: dict[str, object] = field(default_factory=dict)


@dataclass(frozen=True)
class ErcReport:
    errors: int
    warnings: int
    messages: tuple[str, ...]

    @property
    def ok(self) -> bool:
        return self.errors == 0


def _part(sk, ckt, name, ref, value, footprint, pins, description=""):
    p = sk.Part(tool=sk.SKIDL, name=name, ref_prefix=ref.rstrip("0123456789"), ref=ref, value=value,
                footprint=footprint, pins=pins, circuit=ckt, tag=ref, description=description)
    return p


def _pi_header(sk, ckt, used: dict[int, str]):
    """Raspberry Pi 4B J8 header: 40 pins, types from how this design uses them."""
    T = sk.Pin.types
    bcm_at = {phys: bcm for bcm, phys in HEADER_PIN.items()}
    pins = []
    for phys in range(1, 41):
        if phys in HEADER_POWER:
            kind = HEADER_POWER[phys]
            func = T.PWRIN if kind == "GND" else T.PWROUT
            pins.append(sk.Pin(num=phys, name=kind, func=func))
        else:
            bcm = bcm_at[phys]
            role = used.get(bcm, "")
            func = T.BIDIR if (not role or "I2C" in role) else T.OUTPUT
            pins.append(sk.Pin(num=phys, name=f"GPIO{bcm}", func=func))
    return _part(sk, ckt, "RPi4B_J8", "J1", "Raspberry Pi 4B",
                 "Connector_PinSocket_2.54mm:PinSocket_2x20_P2.54mm_Vertical", pins,
                 "Raspberry Pi 4 Model B 40-pin GPIO header (BCM numbering in pin names)")


def _l298n(sk, ckt, k: int):
    T = sk.Pin.types
    names = [("IN1", T.INPUT), ("IN2", T.INPUT), ("IN3", T.INPUT), ("IN4", T.INPUT),
             ("ENA", T.INPUT), ("ENB", T.INPUT), ("OUT1", T.OUTPUT), ("OUT2", T.OUTPUT),
             ("OUT3", T.OUTPUT), ("OUT4", T.OUTPUT), ("VS", T.PWRIN), ("GND", T.PWRIN),
             ("VLOGIC", T.PWRIN)]
    pins = [sk.Pin(num=i + 1, name=n, func=f) for i, (n, f) in enumerate(names)]
    return _part(sk, ckt, "L298N_module", f"U{k + 1}", "L298N", "whisker:L298N_module_43x43mm", pins,
                 "L298N dual H-bridge module (VS=+12V terminal, VLOGIC=+5V terminal)")


def _coil(sk, ckt, i: int, d: Design):
    T = sk.Pin.types
    pins = [sk.Pin(num=1, name="A", func=T.PASSIVE), sk.Pin(num=2, name="B", func=T.PASSIVE)]
    return _part(sk, ckt, "Coil", f"L{i + 1}", f"{d.coil.resistance:g}R {d.coil.turns}T",
                 "whisker:Coil_leads", pins, f"coil of whisker {i} (two soldered leads)")


def _resistor(sk, ckt, i: int, ohm: float, d: Design):
    from whisker.coil.driver import resistor_power_W, resistor_rating_W

    T = sk.Pin.types
    pins = [sk.Pin(num=1, name="1", func=T.PASSIVE), sk.Pin(num=2, name="2", func=T.PASSIVE)]
    watts = resistor_rating_W(resistor_power_W(d))
    return _part(sk, ckt, "R", f"R{i + 1}", f"{ohm:g}R {watts:g}W",
                 "Resistor_THT:R_Axial_DIN0617_L17.0mm_D6.0mm_P25.40mm_Horizontal", pins,
                 f"series resistor of coil {i}: bridge output -> coil A (driver.series_resistance)")


def _supply(sk, ckt, d: Design):
    T = sk.Pin.types
    pins = [sk.Pin(num=1, name="+", func=T.PWROUT), sk.Pin(num=2, name="GND", func=T.PWROUT)]
    return _part(sk, ckt, "DC_supply", "PS1", f"{d.driver.supply_voltage:g}V",
                 "TerminalBlock:TerminalBlock_bornier-2_P5.08mm", pins, "coil supply")


def _led(sk, ckt):
    T = sk.Pin.types
    pins = [sk.Pin(num=1, name="+", func=T.PWRIN), sk.Pin(num=2, name="GND", func=T.PWRIN)]
    return _part(sk, ckt, "LED_strip", "D1", "3528 5V strip", "whisker:LED_strip_pads", pins,
                 "5 V LED strip in the mount's LED channel, fed from the Pi's 5 V header pin")


def _pca9685(sk, ckt, k: int, address: int):
    T = sk.Pin.types
    names = [("GND", T.PWRIN), ("OE", T.INPUT), ("SCL", T.INPUT), ("SDA", T.BIDIR),
             ("VCC", T.PWRIN), ("V+", T.PWRIN)]
    names += [(f"PWM{c}", T.OUTPUT) for c in range(PCA9685_CHANNELS)]
    pins = [sk.Pin(num=i + 1, name=n, func=f) for i, (n, f) in enumerate(names)]
    return _part(sk, ckt, "PCA9685_board", f"U{101 + k}", f"PCA9685 @0x{address:02X}",
                 "whisker:PCA9685_breakout", pins, "16-channel 12-bit I2C PWM board")


def supply_net_name(design: Design) -> str:
    """Name of the coil-supply net, e.g. "+5V"."""
    return f"+{design.driver.supply_voltage:g}V"


def build_circuit(design: Design) -> Board:
    """The driver circuit for `design` (raises PinMapError when the Pi cannot serve N coils)."""
    sk = _skidl()
    with _fast_traces():
        return _build_circuit(sk, design)


def _build_circuit(sk, design: Design) -> Board:
    channels = pin_map(design)
    from whisker.coil.driver import series_resistance_ohm
    from whisker.drive.pins import used_gpio

    series_ohm = series_resistance_ohm(design)

    used = used_gpio(design)
    ckt = sk.Circuit()
    ckt.no_files = True  # no .erc/.log/_sklib.py files in the working directory
    ckt.track_src = False  # no source-file paths in the netlist: it depends only on the design
    board = Board(design, ckt, channels)
    P, N = board.parts, board.nets

    def net(name):
        if name not in N:
            N[name] = sk.Net(name, circuit=ckt)
        return N[name]

    pi = P["J1"] = _pi_header(sk, ckt, used)
    ps = P["PS1"] = _supply(sk, ckt, design)
    led = P["D1"] = _led(sk, ckt)
    v5, gnd = net(supply_net_name(design)), net("GND")
    v5 += ps["+"]
    gnd += ps["GND"], led["GND"]
    led_5v = net("+5V_PI")  # the 5 V strip on the Pi's 5 V rail: the coil supply may be above 5 V
    led_5v += pi[LED_HEADER_PINS[0]], led["+"]
    for phys, kind in HEADER_POWER.items():
        if kind == "GND":
            gnd += pi[phys]

    n = design.whiskers.count
    modules = [_l298n(sk, ckt, k) for k in range(modules_needed(n))]
    own_logic = module_makes_own_logic_supply(design)
    for k, u in enumerate(modules):
        P[u.ref] = u
        v5 += u["VS"]
        gnd += u["GND"]
        if own_logic:  # 5V-EN jumper fitted: the module's regulator drives its +5V terminal
            logic = net(f"U{k + 1}_5V")
            logic += u["VLOGIC"], u["ENA"], u["ENB"]
            logic.drive = sk.POWER
        else:  # supply within the logic range: it feeds VS and the +5V terminal (jumper removed)
            v5 += u["VLOGIC"], u["ENA"], u["ENB"]  # ENA/ENB: the module's jumpers to +5V

    expanders = []
    if design.wiring.expander == "pca9685":
        sda, scl, v33 = net("I2C_SDA"), net("I2C_SCL"), net("+3V3")
        sda += pi[HEADER_PIN[2]]
        scl += pi[HEADER_PIN[3]]
        v33 += pi[1]
        ckt.NC += pi[17]
        for k in range(expander_boards_needed(n)):
            x = _pca9685(sk, ckt, k, design.wiring.pca9685_address + k)
            P[x.ref] = x
            expanders.append(x)
            sda += x["SDA"]
            scl += x["SCL"]
            v33 += x["VCC"]
            gnd += x["GND"], x["OE"]  # /OE low = outputs enabled
            ckt.NC += x["V+"]
    else:
        ckt.NC += pi[1], pi[17]
    # the Pi is powered from its own USB-C supply, not from the header; one 5 V pin feeds the LEDs
    ckt.NC += tuple(pi[p] for p, kind in HEADER_POWER.items() if kind == "5V" and p != LED_HEADER_PINS[0])

    driven = set()
    for ch in channels:
        u = modules[ch.module]
        in_f, in_b, _en, (out_a, out_b) = ch.terminals
        if ch.bus == "gpio":
            src_f, src_b = pi[HEADER_PIN[ch.forward]], pi[HEADER_PIN[ch.backward]]
            driven |= {ch.forward, ch.backward}
        else:
            x = expanders[(ch.address - design.wiring.pca9685_address)]
            src_f, src_b = x[f"PWM{ch.forward}"], x[f"PWM{ch.backward}"]
        coil = P[f"L{ch.whisker + 1}"] = _coil(sk, ckt, ch.whisker, design)
        links = [("FWD", (src_f, u[in_f])), ("BWD", (src_b, u[in_b])), ("B", (u[out_b], coil["B"]))]
        if series_ohm > 0:  # bridge output -> series resistor -> coil A (the paper's dividing circuit)
            res = P[f"R{ch.whisker + 1}"] = _resistor(sk, ckt, ch.whisker, series_ohm, design)
            links += [("OUTA", (u[out_a], res[1])), ("A", (res[2], coil["A"]))]
        else:
            links += [("A", (u[out_a], coil["A"]))]
        for suffix, pins in links:
            net(f"COIL{ch.whisker}_{suffix}").connect(*pins)

    # Unused half of the last module: inputs tied low, outputs open.
    if n % 2 == 1 and modules:
        last = modules[-1]
        gnd += last["IN3"], last["IN4"]
        ckt.NC += last["OUT3"], last["OUT4"]
    # Unused PCA9685 channels and unused Pi GPIO: explicitly not connected.
    used_pwm = {(c.address, c.forward) for c in channels} | {(c.address, c.backward) for c in channels}
    for k, x in enumerate(expanders):
        addr = design.wiring.pca9685_address + k
        for c in range(PCA9685_CHANNELS):
            if (addr, c) not in used_pwm:
                ckt.NC += x[f"PWM{c}"]
    for bcm, phys in HEADER_PIN.items():
        if bcm not in used:
            ckt.NC += pi[phys]
    v5.drive = sk.POWER
    gnd.drive = sk.POWER
    return board


def run_erc(board: Board) -> ErcReport:
    """Run SKiDL's ERC on the board and count its errors and warnings (SKiDL never fails itself)."""
    sk = _skidl()
    from skidl.logger import erc_logger

    records: list[str] = []

    class _Collect(logging.Handler):
        def emit(self, record):
            records.append(f"{record.levelname}: {record.getMessage()}")

    handler = _Collect(level=logging.WARNING)
    erc_logger.addHandler(handler)
    try:
        with contextlib.redirect_stderr(io.StringIO()):
            board.circuit.ERC()
        errors = erc_logger.error.count + erc_logger.bare_error.count
        warnings = erc_logger.warning.count + erc_logger.bare_warning.count
    finally:
        erc_logger.removeHandler(handler)
    del sk
    return ErcReport(errors, warnings, tuple(records))


def netlist_text(board: Board) -> str:
    """KiCad netlist (s-expression) of the board, with the volatile date/source lines made stable."""
    sk = _skidl()
    with contextlib.redirect_stderr(io.StringIO()):
        text = board.circuit.generate_netlist(tool=sk.KICAD8, do_backup=False)
    text = re.sub(r'\(date "[^"]*"\)', f'(date "")', text)
    text = re.sub(r'\(source "[^"]*"\)', '(source "whisker.pcb.netlist")', text)
    return text
