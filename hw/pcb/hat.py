"""The driver HAT's circuit in SKiDL, from the design (whisker.coil.board argues the parts).

Parts are defined in code with the pad numbers of the KiCad 9 footprint each names (pin numbers and
names from the datasheets; tests/test_hat.py compares them with KiCad's symbol libraries where those are
installed), so the netlist and its ERC need no KiCad:

- J1: the Pi's 40-pin header (2x20 socket under the board); coil inputs from ``whisker.drive.pins.pin_map``.
- U1..Uk: DRV8833 (TI SLVSAR1), two coils each: xIN1/xIN2 PWM (forward/backward, as on the L298N),
  nSLEEP on 3V3, xISEN -> sense resistor -> GND, VM 10 uF + VCP 10 nF + VINT 2.2 uF (datasheet 8.2 / 9).
- U11..: INA3221 (TI SBOS576), three coils each: IN+ on the sense resistor's top (xISEN), IN- on GND;
  A0 to GND / VS / SDA / SCL gives 0x40..0x43, so one HAT carries at most 4 x 3 = 12 coils.
- U21: PCA9685 (NXP) when the coils need more PWM than the Pi's GPIO give (wiring.expander).
- U31: the HAT ID EEPROM (CAT24C32 class, 0x50 on ID_SD/ID_SC, WP pulled high, a solder jumper to write).
- J2 supply terminal -> F1 fuse -> Q1 P-FET (reverse polarity: drain to the input, gate to GND) -> VM,
  C1 bulk capacitor; J3 the 5 V LED strip from the Pi's 5 V pin; J10.. one JST PH 2-pin per coil.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from whisker.coil import board as coil_board
from whisker.coil import driver as coil_driver
from whisker.design import Design
from whisker.drive.pins import (HEADER_PIN, HEADER_POWER, LED_HEADER_PINS, PCA9685_CHANNELS, CoilChannel,
                                expander_boards_needed, pin_map)

from .netlist import ErcReport, _fast_traces, _skidl, run_erc

#: KiCad 9 footprints (library:name) of the HAT's parts.
FP = {
    "header": "Connector_PinSocket_2.54mm:PinSocket_2x20_P2.54mm_Vertical",
    "drv8833": "Package_SO:HTSSOP-16-1EP_4.4x5mm_P0.65mm_EP3.4x5mm_Mask2.46x2.31mm_ThermalVias",
    "ina3221": "Package_DFN_QFN:Texas_RGV0016A_VQFN-16-1EP_4x4mm_P0.65mm_EP2.1x2.1mm_ThermalVias",
    "pca9685": "Package_SO:TSSOP-28_4.4x9.7mm_P0.65mm",
    "eeprom": "Package_SO:SOIC-8_3.9x4.9mm_P1.27mm",
    "coil": "Connector_JST:JST_PH_B2B-PH-K_1x02_P2.00mm_Vertical",
    "led": "Connector_JST:JST_PH_B2B-PH-K_1x02_P2.00mm_Vertical",
    "supply": "TerminalBlock_Phoenix:TerminalBlock_Phoenix_MKDS-1,5-2_1x02_P5.00mm_Horizontal",
    "fuse": "Fuse:Fuse_Littelfuse-NANO2-451_453",
    "pfet": "Package_SO:SOIC-8_3.9x4.9mm_P1.27mm",
    "bulk": "Capacitor_SMD:CP_Elec_6.3x7.7",
    "c0603": "Capacitor_SMD:C_0603_1608Metric",
    "c0805": "Capacitor_SMD:C_0805_2012Metric",
    "r0603": "Resistor_SMD:R_0603_1608Metric",
    "r1206": "Resistor_SMD:R_1206_3216Metric",
    "jumper": "Jumper:SolderJumper-2_P1.3mm_Open_RoundedPad1.0x1.5mm",
}

DRV8833_PINS = {1: "nSLEEP", 2: "AOUT1", 3: "AISEN", 4: "AOUT2", 5: "BOUT2", 6: "BISEN", 7: "BOUT1",
                8: "nFAULT", 9: "BIN1", 10: "BIN2", 11: "VCP", 12: "VM", 13: "GND", 14: "VINT", 15: "AIN2",
                16: "AIN1", 17: "PAD"}
#: bridge channel -> (forward input, backward input, sense, (output to coil pin 1, output to coil pin 2))
DRV8833_CHANNEL = {"A": ("AIN1", "AIN2", "AISEN", ("AOUT1", "AOUT2")),
                   "B": ("BIN1", "BIN2", "BISEN", ("BOUT1", "BOUT2"))}
INA3221_PINS = {1: "IN-3", 2: "IN+3", 3: "GND", 4: "VS", 5: "A0", 6: "SCL", 7: "SDA", 8: "WARNING",
                9: "CRITICAL", 10: "PV", 11: "IN-1", 12: "IN+1", 13: "TC", 14: "IN-2", 15: "IN+2", 16: "VPU",
                17: "EP"}
INA3221_A0 = ("GND", "+3V3", "I2C_SDA", "I2C_SCL")   # A0 strap -> 0x40, 0x41, 0x42, 0x43 (SBOS576 table 1)
PCA9685_PINS = {**{i + 1: f"A{i}" for i in range(5)}, **{6 + i: f"LED{i}" for i in range(8)}, 14: "VSS",
                **{15 + i: f"LED{8 + i}" for i in range(8)}, 23: "OE", 24: "A5", 25: "EXTCLK", 26: "SCL",
                27: "SDA", 28: "VDD"}
EEPROM_PINS = {1: "A0", 2: "A1", 3: "A2", 4: "GND", 5: "SDA", 6: "SCL", 7: "WP", 8: "VCC"}
#: Raspberry Pi ID EEPROM pins (HAT specification): GPIO0 = ID_SD, GPIO1 = ID_SC.
ID_SD, ID_SC = 0, 1
#: Fast-acting fuse ratings (A) of the Littelfuse NANO2 451/453 series.
FUSE_RATINGS_A = (1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 7.0, 8.0, 10.0, 12.0, 15.0)
#: A fuse runs at <= 75 % of its rating (Littelfuse's derating guidance for continuous current).
FUSE_LOAD = 0.75
#: Per-bridge capacitors from the DRV8833 datasheet (SLVSAR1, 8.2 typical application / 9 power supply).
DRV8833_CAPS = (("VM", "GND", "10uF 16V X7R", "c0805"), ("VCP", "VM", "10nF 16V X7R", "c0603"),
                ("VINT", "GND", "2.2uF 6.3V X7R", "c0603"))


class HatError(ValueError):
    """The design does not fit the HAT (one-line message naming the limit)."""


@dataclass
class Hat:
    design: Design
    circuit: object
    channels: list[CoilChannel]
    parts: dict = field(default_factory=dict)      # ref -> SKiDL Part
    nets: dict = field(default_factory=dict)       # name -> SKiDL Net
    info: dict = field(default_factory=dict)       # ref -> {"footprint", "value", "kind", "mpn", "block"}


def bridges_needed(n: int) -> int:
    return math.ceil(n / 2)


def monitors_needed(n: int, design: Design) -> int:
    return math.ceil(n / coil_driver.monitor(design.driver.current_monitor).channels)


def fuse_rating_A(design: Design) -> float:
    """Smallest NANO2 rating that carries every coil at full scale at <= FUSE_LOAD of the rating, A."""
    total = design.whiskers.count * coil_board.full_scale_current_A(design)
    for r in FUSE_RATINGS_A:
        if total <= FUSE_LOAD * r:
            return r
    raise HatError(f"{total:.2f} A for {design.whiskers.count} coils needs a fuse above {FUSE_RATINGS_A[-1]:g} A")


def check(design: Design) -> None:
    """One-line refusals: unknown bridge/monitor, a coil current above the bridge's rating, more coils
    than the HAT carries, an expander address on top of the monitors'."""
    try:
        br = coil_driver.bridge(design.driver.bridge)
        mon = coil_driver.monitor(design.driver.current_monitor)
    except coil_driver.DriverError as err:
        raise HatError(str(err)) from None
    if br.name != "DRV8833":
        raise HatError(f"the HAT is laid out for the DRV8833 (driver.bridge = {design.driver.bridge!r} is in "
                       "hw/bridges.csv for the comparison only)")
    if mon.name != "INA3221":
        raise HatError(f"the HAT is laid out for the INA3221 (driver.current_monitor = {mon.name!r})")
    n = design.whiskers.count
    top = coil_board.max_coils_for(mon)
    if n > top:
        raise HatError(f"{n} coils is more than the HAT carries: {top} ({mon.addresses} {mon.name} I2C addresses "
                       f"x {mon.channels} channels)")
    try:
        coil_board.check(design)
    except coil_board.BoardError as err:
        raise HatError(str(err)) from None
    if design.wiring.expander == "pca9685" and design.wiring.pca9685_address < 0x40 + mon.addresses:
        raise HatError(f"wiring.pca9685_address = 0x{design.wiring.pca9685_address:02X} collides with the HAT's "
                       f"{mon.name} monitors at 0x40..0x{0x40 + mon.addresses - 1:02X}; set it to 0x44 or above")
    fuse_rating_A(design)


def build_circuit(design: Design) -> Hat:
    """The HAT circuit for `design` (HatError / PinMapError when it does not fit)."""
    check(design)
    sk = _skidl()
    with _fast_traces():
        return _build(sk, design)


def _build(sk, design: Design) -> Hat:
    T = sk.Pin.types
    channels = pin_map(design)
    n = design.whiskers.count
    ckt = sk.Circuit()
    ckt.no_files = True
    ckt.track_src = False
    hat = Hat(design, ckt, channels)
    P, N = hat.parts, hat.nets
    block = ["pi"]   # the functional block the next parts belong to (the schematic's sheets)

    def net(name):
        if name not in N:
            N[name] = sk.Net(name, circuit=ckt)
        return N[name]

    def part(ref, name, value, fp, pins, kind, mpn="", desc=""):
        p = sk.Part(tool=sk.SKIDL, name=name, ref_prefix=ref.rstrip("0123456789"), ref=ref, value=value,
                    footprint=FP[fp], pins=[sk.Pin(num=k, name=nm, func=f) for k, nm, f in pins], circuit=ckt,
                    tag=ref, description=desc)
        P[ref] = p
        hat.info[ref] = {"footprint": FP[fp], "value": value, "kind": kind, "mpn": mpn, "block": block[0]}
        return p

    def two(ref, value, fp, kind, mpn="", a="1", b="2"):
        return part(ref, kind, value, fp, [(1, a, T.PASSIVE), (2, b, T.PASSIVE)], kind, mpn)

    counter = {"C": 0, "R": 0}

    def passive(prefix, kind, a, b, value, fp, mpn=""):
        """The next C<n> / R<n> between nets a and b."""
        counter[prefix] += 1
        p = two(f"{prefix}{counter[prefix]}", value, fp, kind, mpn)
        net(a).connect(p[1])
        net(b).connect(p[2])
        return p

    def cap(a, b, value, fp, mpn=""):
        return passive("C", "capacitor", a, b, value, fp, mpn)

    def res(a, b, value, fp, mpn=""):
        return passive("R", "resistor", a, b, value, fp, mpn)

    # --- the Pi header: every pin typed by its use -------------------------------------------------
    used = {}
    for ch in channels:
        if ch.bus == "gpio":
            used[ch.forward] = used[ch.backward] = T.OUTPUT
    hdr_pins = []
    bcm_at = {phys: bcm for bcm, phys in HEADER_PIN.items()}
    for phys in range(1, 41):
        if phys in HEADER_POWER:
            kind = HEADER_POWER[phys]
            hdr_pins.append((phys, kind, T.PWRIN if kind == "GND" else T.PWROUT))
        else:
            hdr_pins.append((phys, f"GPIO{bcm_at[phys]}", used.get(bcm_at[phys], T.BIDIR)))
    j1 = part("J1", "RPi_40pin", "RPi 40-pin socket", "header", hdr_pins, "header", "2x20 2.54 mm female, 8.5 mm",
              "Raspberry Pi 40-pin header, socket under the HAT")
    gnd, v33, vm = net("GND"), net("+3V3"), net("VM")
    for phys, kind in HEADER_POWER.items():
        if kind == "GND":
            gnd += j1[phys]
    v33 += j1[1]   # one 3V3 pin (two POWER-OUT pins on one net would be an ERC error)
    ckt.NC += j1[17]
    v5 = net("+5V_PI")
    v5 += j1[LED_HEADER_PINS[0]]
    ckt.NC += tuple(j1[p] for p, kind in HEADER_POWER.items() if kind == "5V" and p != LED_HEADER_PINS[0])
    sda, scl = net("I2C_SDA"), net("I2C_SCL")
    sda += j1[HEADER_PIN[2]]
    scl += j1[HEADER_PIN[3]]

    # --- supply: terminal, fuse, reverse-polarity P-FET, bulk -------------------------------------
    block[0] = "supply"
    j2 = part("J2", "Supply", f"{design.driver.supply_voltage:g} V in", "supply",
              [(1, "+", T.PWROUT), (2, "GND", T.PWROUT)], "connector", "Phoenix MKDS 1,5/2-5,08")
    fuse = fuse_rating_A(design)
    f1 = two("F1", f"{fuse:g}A fast", "fuse", "fuse", f"Littelfuse 0451{int(fuse * 1000):04d}")
    q1 = part("Q1", "PMOS", "AO4407A", "pfet",
              [(1, "S1", T.PASSIVE), (2, "S2", T.PASSIVE), (3, "S3", T.PASSIVE), (4, "G", T.INPUT),
               (5, "D1", T.PASSIVE), (6, "D2", T.PASSIVE), (7, "D3", T.PASSIVE), (8, "D4", T.PASSIVE)],
              "pfet", "AO4407A (-30 V, -12 A, 14 mOhm at -4.5 V)", "reverse-polarity protection")
    # drain to the (fused) input: a reversed supply meets the body diode blocking and the gate off
    net("VIN").connect(j2["+"], f1[1])
    net("VIN_F").connect(f1[2], q1["D1"], q1["D2"], q1["D3"], q1["D4"])
    vm += q1["S1"], q1["S2"], q1["S3"]
    gnd += j2["GND"]
    res("QG", "GND", "10k", "r0603")
    net("QG").connect(q1["G"])
    cb = two("C100", "100uF 16V", "bulk", "capacitor", "electrolytic 6.3x7.7 mm", a="+", b="-")
    vm += cb["+"]
    gnd += cb["-"]
    vm.drive = sk.POWER
    gnd.drive = sk.POWER

    # --- bridges ---------------------------------------------------------------------------------
    rs = coil_board.sense_resistance_ohm(design)
    bridges = []
    for k in range(bridges_needed(n)):
        block[0] = f"bridge{k + 1}"
        u = part(f"U{k + 1}", "DRV8833", "DRV8833PWP", "drv8833",
                 [(num, nm, {"AOUT1": T.OUTPUT, "AOUT2": T.OUTPUT, "BOUT1": T.OUTPUT, "BOUT2": T.OUTPUT,
                             "VM": T.PWRIN, "GND": T.PWRIN, "PAD": T.PWRIN, "nSLEEP": T.INPUT,
                             "nFAULT": T.OPENCOLL, "VINT": T.PWROUT, "VCP": T.PWROUT}.get(
                     nm, T.INPUT if "IN" in nm else T.PASSIVE)) for num, nm in DRV8833_PINS.items()],
                 "bridge", "TI DRV8833PWPR", "dual H-bridge, two coils")
        bridges.append(u)
        v33 += u["nSLEEP"]
        vm += u["VM"]
        gnd += u["GND"], u["PAD"]
        ckt.NC += u["nFAULT"]
        vint, vcp = net(f"U{k + 1}_VINT"), net(f"U{k + 1}_VCP")
        vint += u["VINT"]
        vcp += u["VCP"]
        vint.drive = vcp.drive = sk.POWER
        cap("VM", "GND", DRV8833_CAPS[0][2], DRV8833_CAPS[0][3])
        cap(f"U{k + 1}_VCP", "VM", DRV8833_CAPS[1][2], DRV8833_CAPS[1][3])
        cap(f"U{k + 1}_VINT", "GND", DRV8833_CAPS[2][2], DRV8833_CAPS[2][3])

    # --- monitors --------------------------------------------------------------------------------
    monitors = []
    block[0] = "monitors"
    for m in range(monitors_needed(n, design)):
        u = part(f"U{11 + m}", "INA3221", "INA3221AIRGVR", "ina3221",
                 [(num, nm, {"GND": T.PWRIN, "EP": T.PWRIN, "VS": T.PWRIN, "SDA": T.BIDIR, "SCL": T.INPUT,
                             "WARNING": T.OPENCOLL, "CRITICAL": T.OPENCOLL, "PV": T.OPENCOLL, "TC": T.OPENCOLL}
                  .get(nm, T.INPUT)) for num, nm in INA3221_PINS.items()],
                 "monitor", "TI INA3221AIRGVR", "3-channel current monitor")
        monitors.append(u)
        v33 += u["VS"]
        gnd += u["GND"], u["EP"]
        sda += u["SDA"]
        scl += u["SCL"]
        net(INA3221_A0[m]).connect(u["A0"])
        ckt.NC += u["WARNING"], u["CRITICAL"], u["PV"], u["TC"], u["VPU"]
        cap("+3V3", "GND", "100nF", "c0603")

    # --- expander --------------------------------------------------------------------------------
    expanders = []
    block[0] = "expander"
    if any(ch.bus == "pca9685" for ch in channels):
        addr0 = design.wiring.pca9685_address
        for k in range(expander_boards_needed(n)):
            addr = addr0 + k
            x = part(f"U{21 + k}", "PCA9685", f"PCA9685PW @0x{addr:02X}", "pca9685",
                     [(num, nm, T.OUTPUT if nm.startswith("LED") else
                       {"VSS": T.PWRIN, "VDD": T.PWRIN, "SDA": T.BIDIR}.get(nm, T.INPUT))
                      for num, nm in PCA9685_PINS.items()], "expander", "NXP PCA9685PW")
            expanders.append(x)
            v33 += x["VDD"]
            gnd += x["VSS"], x["OE"], x["EXTCLK"]
            sda += x["SDA"]
            scl += x["SCL"]
            for bit in range(6):
                (v33 if (addr - 0x40) >> bit & 1 else gnd).connect(x[f"A{bit}"])
            cap("+3V3", "GND", "100nF", "c0603")

    # --- the ID EEPROM ---------------------------------------------------------------------------
    block[0] = "pi"
    e = part("U31", "EEPROM", "CAT24C32", "eeprom",
             [(num, nm, {"GND": T.PWRIN, "VCC": T.PWRIN, "SDA": T.BIDIR}.get(nm, T.INPUT))
              for num, nm in EEPROM_PINS.items()], "eeprom", "onsemi CAT24C32WI-GT3", "HAT ID EEPROM")
    v33 += e["VCC"]
    gnd += e["GND"], e["A0"], e["A1"], e["A2"]
    net("ID_SD").connect(e["SDA"], j1[HEADER_PIN.get(ID_SD, 27)])
    net("ID_SC").connect(e["SCL"], j1[HEADER_PIN.get(ID_SC, 28)])
    net("EE_WP").connect(e["WP"])
    res("EE_WP", "+3V3", "10k", "r0603")
    jp = two("JP1", "WP", "jumper", "jumper", "solder jumper: close to write the EEPROM")
    net("EE_WP").connect(jp[1])
    gnd += jp[2]
    res("ID_SD", "+3V3", "3.9k", "r0603")
    res("ID_SC", "+3V3", "3.9k", "r0603")
    cap("+3V3", "GND", "100nF", "c0603")

    # --- LED strip connector -----------------------------------------------------------------------
    j3 = part("J3", "LED", "LED 5V", "led", [(1, "+", T.PWRIN), (2, "GND", T.PWRIN)], "connector",
              "JST B2B-PH-K-S", "5 V LED strip from the Pi's 5 V pin")
    v5 += j3["+"]
    gnd += j3["GND"]
    v5.drive = sk.POWER
    v33.drive = sk.POWER

    # --- coils -------------------------------------------------------------------------------------
    driven_pwm = set()
    for ch in channels:
        u = bridges[ch.module]
        fwd, bwd, sense, (out1, out2) = DRV8833_CHANNEL[ch.channel]
        i = ch.whisker
        block[0] = f"bridge{ch.module + 1}"
        if ch.bus == "gpio":
            src_f, src_b = j1[HEADER_PIN[ch.forward]], j1[HEADER_PIN[ch.backward]]
        else:
            x = expanders[ch.address - design.wiring.pca9685_address]
            src_f, src_b = x[f"LED{ch.forward}"], x[f"LED{ch.backward}"]
            driven_pwm |= {(ch.address, ch.forward), (ch.address, ch.backward)}
        net(f"COIL{i}_FWD").connect(src_f, u[fwd])
        net(f"COIL{i}_BWD").connect(src_b, u[bwd])
        jc = part(f"J{10 + i}", "Coil", f"W{i}", "coil", [(1, "A", T.PASSIVE), (2, "B", T.PASSIVE)], "connector",
                  "JST B2B-PH-K-S", f"coil of whisker {i}")
        net(f"COIL{i}_A").connect(u[out1], jc["A"])
        net(f"COIL{i}_B").connect(u[out2], jc["B"])
        isen = net(f"ISEN{i}")
        isen += u[sense]
        res(f"ISEN{i}", "GND", f"{rs:g}R 1% 0.25W", "r1206", "current sense, 1 %")
        m, c = divmod(i, 3)
        isen += monitors[m][f"IN+{c + 1}"]
        gnd += monitors[m][f"IN-{c + 1}"]
    if n % 2:  # the spare half of the last bridge: inputs low, sense to GND, outputs open
        u = bridges[-1]
        gnd += u["BIN1"], u["BIN2"], u["BISEN"]
        ckt.NC += u["BOUT1"], u["BOUT2"]
    for c in range(n, 3 * len(monitors)):  # spare monitor channels: both inputs on GND
        m, k = divmod(c, 3)
        gnd += monitors[m][f"IN+{k + 1}"], monitors[m][f"IN-{k + 1}"]
    for k, x in enumerate(expanders):
        for c in range(PCA9685_CHANNELS):
            if (design.wiring.pca9685_address + k, c) not in driven_pwm:
                ckt.NC += x[f"LED{c}"]
    taken = {HEADER_PIN[g] for ch in channels if ch.bus == "gpio" for g in (ch.forward, ch.backward)}
    taken |= {HEADER_PIN[2], HEADER_PIN[3], HEADER_PIN[ID_SD], HEADER_PIN[ID_SC]}
    for bcm, phys in HEADER_PIN.items():
        if phys not in taken:
            ckt.NC += j1[phys]
    return hat


def erc(hat: Hat) -> ErcReport:
    return run_erc(hat)


def pad_nets(hat: Hat) -> dict[str, dict[str, str]]:
    """ref -> {pad number: net name} of every connected pin (what the board file gets)."""
    out: dict[str, dict[str, str]] = {}
    for name, n in hat.nets.items():
        for p in n.pins:
            out.setdefault(p.part.ref, {})[str(p.num)] = name
    return out
