"""Wiring diagram (PNG) of the coil driver: Pi header -> (PCA9685) -> L298N modules -> coils.

Drawn with matplotlib from the same pin map as everything else. One colour per coil.
"""

from __future__ import annotations

from pathlib import Path

from whisker.design import Design
from whisker.drive.pins import (HEADER_PIN, HEADER_POWER, LED_HEADER_PINS, RESERVED, module_makes_own_logic_supply,
                          modules_needed, pin_map, used_gpio)


PITCH = 0.42  # drawing units between header pins (drawn as one column, pin 1 on top)


def _header_xy(phys: int) -> tuple[float, float]:
    """Position of a header pin in the drawing: one column, pin 1 on top (wires all leave right)."""
    return 0.6, -(phys - 1) * PITCH


def draw(design: Design, path: str | Path | None = None):
    """Draw the wiring diagram; save it as PNG at `path` if given. Returns the figure."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, FancyBboxPatch, Rectangle

    from whisker.coil.driver import series_resistance_ohm

    chans = pin_map(design)
    series_ohm = series_resistance_ohm(design)
    n = design.whiskers.count
    mods = modules_needed(n)
    expander = design.wiring.expander == "pca9685"
    used = used_gpio(design)
    cmap = plt.get_cmap("tab20")
    palette = [cmap(i) for i in (0, 2, 4, 8, 10, 12, 16, 18, 1, 3, 5, 9, 11, 13, 17, 19)]  # no red/grey
    colour = [palette[i % len(palette)] for i in range(n)]

    mod_h = 3.2
    top = 0.5
    height = max(40 * PITCH + 1.5, mods * (mod_h + 0.6) + 1.5)
    fig, ax = plt.subplots(figsize=(13, max(7.0, height * 0.62)))
    ax.set_aspect("equal")
    ax.axis("off")

    # --- Raspberry Pi header
    ax.add_patch(FancyBboxPatch((-1.2, -39 * PITCH - 0.3), 2.0, 40 * PITCH + 0.1,
                                boxstyle="round,pad=0.05", fc="#e8f5e9", ec="#2e7d32"))
    ax.text(-0.2, top + 0.05, "Raspberry Pi 4B\nJ8 header", ha="center", va="bottom", fontsize=9,
            weight="bold")
    bcm_at = {p: g for g, p in HEADER_PIN.items()}
    owner = {}
    for c in chans:
        if c.bus == "gpio":
            owner[c.forward] = c.whisker
            owner[c.backward] = c.whisker
    for phys in range(1, 41):
        x, y = _header_xy(phys)
        if phys in HEADER_POWER:
            label, fc = HEADER_POWER[phys], ("#333333" if HEADER_POWER[phys] == "GND" else "#e53935")
        else:
            g = bcm_at[phys]
            label = f"GPIO{g}"
            fc = colour[owner[g]] if g in owner else ("#ffb300" if g in used else
                                                      ("#9e9e9e" if g in RESERVED else "white"))
        ax.add_patch(Circle((x, y), 0.14, fc=fc, ec="black", lw=0.6))
        ax.text(x - 0.22, y, f"({phys}) {label}", ha="right", va="center", fontsize=6)

    # --- L298N modules
    mx = 6.5
    term_y = {}
    for k in range(mods):
        y0 = top - 0.3 - k * (mod_h + 0.6)
        ax.add_patch(FancyBboxPatch((mx, y0 - mod_h), 2.2, mod_h, boxstyle="round,pad=0.05",
                                    fc="#e3f2fd", ec="#1565c0"))
        ax.text(mx + 1.1, y0 - mod_h / 2, f"U{k + 1}\n{design.driver.type}\nENA/ENB\njumpered",
                ha="center", va="center", fontsize=7)
        for j, name in enumerate(("IN1", "IN2", "IN3", "IN4")):
            yy = y0 - 0.5 - j * 0.7
            term_y[(k, name)] = (mx, yy)
            ax.text(mx + 0.08, yy, name, fontsize=6, va="center")
        for j, name in enumerate(("OUT1", "OUT2", "OUT3", "OUT4")):
            yy = y0 - 0.5 - j * 0.7
            term_y[(k, name)] = (mx + 2.2, yy)
            ax.text(mx + 2.12, yy, name, fontsize=6, va="center", ha="right")

    # --- PCA9685 boards (optional)
    src_xy = {}
    if expander:
        addrs = sorted({c.address for c in chans})
        for b, addr in enumerate(addrs):
            bx, by = 3.0, top - 0.3 - b * 9.2
            ax.add_patch(FancyBboxPatch((bx, by - 8.2), 1.8, 8.2, boxstyle="round,pad=0.05",
                                        fc="#fff8e1", ec="#ff8f00"))
            ax.text(bx + 0.9, by + 0.05, f"PCA9685\n0x{addr:02X}", ha="center", va="bottom", fontsize=7)
            for ch in range(16):
                src_xy[(addr, ch)] = (bx + 1.8, by - 0.3 - ch * 0.5)
                ax.text(bx + 1.72, by - 0.3 - ch * 0.5, f"PWM{ch}", fontsize=5, ha="right", va="center")
            for gpio, name, dy in ((2, "SDA", -7.6), (3, "SCL", -7.9)):
                px, py = _header_xy(HEADER_PIN[gpio])
                ax.plot([px + 0.14, bx], [py, by + dy], color="#ff8f00", lw=1)
                ax.text(bx + 0.08, by + dy, name, fontsize=5, va="center")

    # --- wires and coils
    for c in chans:
        in_f, in_b, _en, (out_a, out_b) = c.terminals
        for pin, term in ((c.forward, in_f), (c.backward, in_b)):
            if c.bus == "gpio":
                sx, sy = _header_xy(HEADER_PIN[pin])
                sx += 0.14
            else:
                sx, sy = src_xy[(c.address, pin)]
            tx, ty = term_y[(c.module, term)]
            midx = 1.4 + 0.4 * c.whisker + (0.2 if term in ("IN2", "IN4") else 0.0)
            if c.bus != "gpio":
                midx = 5.3 + 0.08 * c.whisker
            ax.plot([sx, midx, midx, tx], [sy, sy, ty, ty], color=colour[c.whisker], lw=1.4)
        (ax_, ay_), (bx_, by_) = term_y[(c.module, out_a)], term_y[(c.module, out_b)]
        cx, cy = mx + 3.6, (ay_ + by_) / 2
        ax.plot([ax_, cx - 0.3], [ay_, cy + 0.1], color=colour[c.whisker], lw=1.4)
        if series_ohm > 0:  # the series resistor on the A lead, drawn as a box with its reference
            rx, ry = (ax_ + cx - 0.3) / 2, (ay_ + cy + 0.1) / 2
            ax.add_patch(Rectangle((rx - 0.22, ry - 0.07), 0.44, 0.14, fc="white", ec="black", lw=0.8, zorder=3))
            ax.text(rx, ry + 0.12, f"R{c.whisker + 1}", fontsize=5, ha="center", va="bottom")
        ax.plot([bx_, cx - 0.3], [by_, cy - 0.1], color=colour[c.whisker], lw=1.4)
        ax.add_patch(Circle((cx, cy), 0.3, fc=colour[c.whisker], ec="black"))
        ax.text(cx + 0.45, cy, f"coil {c.whisker}\n{design.whisker_angles_deg[c.whisker]:g} deg",
                fontsize=7, va="center")

    ax.text(-0.2, -40 * PITCH - 0.2, "grey: kept free (ID EEPROM, I2C, UART)\nwhite: unused",
            ha="center", va="top", fontsize=6)
    ax.text(mx + 1.1, -height + 1.6,
            f"+{design.driver.supply_voltage:g} V supply -> "
            + ("VS of every module (5V-EN jumper fitted)" if module_makes_own_logic_supply(design)
               else "VS, +5V, ENA/ENB of every module (5V-EN jumper off)")
            + f";\nsupply GND -> module GND and Pi GND (pin 6);\n5 V LED strip on Pi pins {LED_HEADER_PINS[0]} (5V) "
            f"and {LED_HEADER_PINS[1]} (GND)"
            + (f";\nR1..R{n}: {series_ohm:g} ohm series resistor in each coil's A lead" if series_ohm > 0 else ""),
            ha="center", va="top", fontsize=7)
    ax.set_title(f"Coil driver wiring: {n} coils, {mods} x {design.driver.type}"
                 + (f", PCA9685 expander" if expander else ", direct GPIO (PWM on IN pins)"),
                 fontsize=10)
    ax.set_xlim(-2.5, mx + 5.5)
    ax.set_ylim(-height, top + 1.2)
    fig.tight_layout()
    if path is not None:
        from whisker.files import atomic_write_bytes
        import io

        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=110, metadata={"Software": None})
        atomic_write_bytes(path, buf.getvalue())
    return fig
