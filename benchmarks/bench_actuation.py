"""Actuation safety and recording: what accuracy and crash safety cost.

A. Thermal guard: the winding estimate against its own model (the thermal network) at a fine,
   extrapolated step over a grasp-like drive profile, for several guard update periods (the watchdog's
   drive.guard_period), with the time per update; and the cheaper one-node coil model as a guard.
B. What the guard means for the paper's coil: time at full level until the cut, the duty cycle
   under policy "cut", the level "derate" settles at, at the paper's 3 V and at 100 % duty, with
   the design's series resistor and without it (driver.series_resistance=0).
C. Recording: milliseconds and bytes per 640x480 frame for PNG / JPEG, with and without fsync
   (the crash safety against power loss; SIGKILL alone is survived either way).

Writes benchmarks/results/actuation.md, actuation_guard.csv, actuation_recording.csv and
actuation_guard.png (atomically).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import best_time_s, machine_line, markdown_table, save_figure, write_csv, write_text  # noqa: E402

from whisker.design import default_design  # noqa: E402
from whisker.coil.driver import series_resistance_ohm  # noqa: E402
from whisker.drive.guard import ThermalGuard, coil_current_A, full_scale_voltage, volts_to_levels  # noqa: E402
from whisker.coil.thermal import CoilThermal  # noqa: E402


class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def profile(t):
    """Requested level over time: full 1.5 s (retract), 0.5 for 3 s (hold), off (release)."""
    return 1.0 if t < 1.5 else 0.5 if t < 4.5 else 0.0


REF_STEP_S = 0.0005   # the reference's step: the same network, Richardson-extrapolated from 1 and 0.5 ms


def reference(design, t_end):
    """(times, winding C) of the guard's own model (the thermal network) at REF_STEP_S and 2 x REF_STEP_S,
    Richardson-extrapolated (its step is first order): the update period's error is measured against
    the same physics, not against another model."""
    ts1, c1 = guard_run(design, 2 * REF_STEP_S, t_end, substep_s=2 * REF_STEP_S)
    ts2, c2 = guard_run(design, REF_STEP_S, t_end, substep_s=REF_STEP_S)
    return ts1, 2 * c2[::2] - c1


def guard_run(design, period, t_end, substep_s=0.05, thermal=None):
    clock = Clock()
    g = ThermalGuard(design, clock=clock, policy="cut", max_substep_s=substep_s, thermal=thermal)
    g.cut_C = g.derate_from_C = 1e9  # measure the estimate only: never cut (the one-node model's terms)
    g.resume_C = 1e9
    g.margin_K = -1e9                # ... nor on any material's headroom (the network's terms)
    ts, temps = [0.0], [g.ambient_C]
    req = np.full(design.whiskers.count, profile(0.0))
    g.allow(req, 0.0)  # the level is applied at t = 0
    steps = int(round(t_end / period))
    for k in range(steps):
        clock.t = (k + 1) * period
        req[:] = profile(clock.t)  # integrates the previous interval, then applies the new level
        g.allow(req, clock.t)
        ts.append(clock.t)
        temps.append(g.temperatures[0])
    return np.array(ts), np.array(temps)


def part_a(design):
    """The guard's update period against its temperature error (the network, as the guard runs it),
    and the cheaper one-node coil model (whisker.coil.thermal.CoilThermal) at the watchdog's period."""
    rows = []
    t_end = 8.0
    curves = {}
    ref_t, ref_c = reference(design, t_end)
    variants = [("network", period, None) for period in (0.005, 0.02, 0.1, 0.5)]
    variants.append(("one-node", float(design.drive.guard_period), CoilThermal(design)))
    for model, period, thermal in variants:
        ts, temps = guard_run(design, period, t_end, thermal=thermal)
        ref = np.interp(ts, ref_t, ref_c)
        err = np.abs(temps - ref)
        clock = Clock()
        g = ThermalGuard(design, clock=clock, thermal=thermal)
        req = np.full(design.whiskers.count, 0.5)

        def one():
            clock.t += period
            g.allow(req, clock.t)

        us = best_time_s(one, repeat=5, number=50) * 1e6
        signed = temps - ref
        rows.append({"model": model, "update_period_s": period, "max_error_K": float(err.max()),
                     "most_under_K": float(min(0.0, signed.min())),
                     "error_at_peak_K": float(err[np.argmax(ref)]), "us_per_update_8_coils": us,
                     "cpu_share_pct": us / (period * 1e6) * 100})
        curves[(model, period)] = (ts, temps, ref)
    return rows, curves


def time_to_margin(design, level, t_max=600.0, dt=0.01):
    """Seconds for a coil held at `level` from ambient until its weakest material comes within
    drive.guard_margin of its own limit, in the guard's model (the thermal network), and that material;
    (inf, "") if never within t_max."""
    clock = Clock()
    g = ThermalGuard(design, clock=clock, policy="cut")
    margin = g.margin_K
    g.margin_K = -1e9       # follow the model only: never trip
    req = np.full(design.whiskers.count, level)
    g.allow(req, 0.0)
    for k in range(int(t_max / dt)):
        clock.t = (k + 1) * dt
        g.allow(req, clock.t)
        if g.headroom_K[0] <= margin:
            return clock.t, g.limited_by[0]
    return float("inf"), ""


def part_b(design):
    """Both drives of the coil: the design's (default: the 5.1 ohm series resistor) and the bare bridge."""
    out = []
    for design_label, d in (("series resistor", design),
                            ("no resistor", default_design("driver.series_resistance=0"))):
        out += _part_b_one(d, design_label)
    return out


def _part_b_one(design, design_label):
    out = []
    th = CoilThermal(design)
    vfs = full_scale_voltage(design)
    rs = series_resistance_ohm(design)
    for label, level in (("3 V (paper)", float(volts_to_levels(design, design.actuation.voltage))),
                         ("100 % duty", 1.0)):
        i_cold = coil_current_A(design, vfs, 20.0)
        model_t, model_by = time_to_margin(design, level)
        for policy in ("cut", "derate"):
            clock = Clock()
            g = ThermalGuard(design, clock=clock, policy=policy)
            req = np.full(design.whiskers.count, level)
            dt, t_end = 0.02, 300.0
            g.allow(req, 0.0)  # switched on at t = 0
            applied, t_first_change = [], None
            for k in range(int(t_end / dt)):
                clock.t = (k + 1) * dt
                a = g.allow(req, clock.t)[0]
                applied.append(a)
                if t_first_change is None and a < level - 1e-9:
                    t_first_change = clock.t
            applied = np.array(applied)
            last = applied[len(applied) // 2:]
            out.append({"series_ohm": rs, "full_scale_V": vfs, "drive": label, "level": round(level, 4),
                        "coil_W_cold": level * i_cold ** 2 * float(th.resistance(20.0)),
                        "resistor_W_cold": level * i_cold ** 2 * rs, "policy": policy,
                        "full_level_for_s": t_first_change if t_first_change is not None else float("inf"),
                        "mean_level_after_150s": float(last.mean()),
                        "peak_winding_C": float(g.peak_C[0]), "trips": int(g.trips[0]),
                        "model_time_to_margin_s": model_t,
                        "limited_by": (g.trip_reason[0] or g.limited_by[0]) if policy == "cut" else model_by})
    return out


def part_c(design):
    import cv2

    from whisker.vision import render
    from whisker.data.recording import Recorder

    img = render.render_frame(design, render.scene_markers(design, np.full(design.whiskers.count, 5.0)), seed=1)
    rows = []
    track_rows = [f"0,0.1,{w},200.1,300.2,1.5,-0.5,1,ok,0.5,0.6,0.2,64.4" for w in range(design.whiskers.count)]
    for fmt in ("png", "jpg"):
        for fsync in (True, False):
            with tempfile.TemporaryDirectory() as tmp:
                rec = Recorder(Path(tmp) / "s", design, image_format=fmt, fsync=fsync)
                i = [0]

                def one():
                    rec.write_frame(i[0], img, track_rows=track_rows)
                    rec.log_guard(np.full(design.whiskers.count, 30.0))
                    i[0] += 1

                ms = best_time_s(one, repeat=5, number=10) * 1e3
                size = (Path(tmp) / "s" / "frames" / f"000000.{fmt}").stat().st_size
                rec.close()
            rows.append({"image": fmt, "fsync": fsync, "ms_per_frame": ms, "kB_per_frame": size / 1024,
                         "max_fps": 1000.0 / ms})
    t_png = best_time_s(lambda: cv2.imencode(".png", img), repeat=5, number=5) * 1e3
    t_jpg = best_time_s(lambda: cv2.imencode(".jpg", img), repeat=5, number=5) * 1e3
    return rows, t_png, t_jpg


def main():
    design = default_design()
    a_rows, curves = part_a(design)
    b_rows = part_b(design)
    c_rows, t_png, t_jpg = part_c(design)
    write_csv("actuation_guard.csv", a_rows)
    write_csv("actuation_guard_policies.csv", b_rows)
    write_csv("actuation_recording.csv", c_rows)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4))
    for (model, period), (ts, temps, ref) in curves.items():
        ax1.plot(ts, temps, label=f"guard ({model}), update {period * 1000:g} ms")
        ax2.semilogy(ts, np.abs(temps - ref) + 1e-6, label=f"{model}, {period * 1000:g} ms")
    ts, _, ref = curves[("network", 0.005)]
    ax1.plot(ts, ref, "k--", lw=1, label=f"reference (network, {REF_STEP_S * 1000:g} ms, extrapolated)")
    ax1.set_xlabel("time (s)")
    ax1.set_ylabel("winding temperature (C)")
    ax1.set_title("full level 1.5 s, level 0.5 for 3 s, off")
    ax1.legend(fontsize=8)
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("|estimate - reference| (K)")
    ax2.legend(fontsize=8)
    ax2.grid(alpha=0.3)
    save_figure(fig, "actuation_guard.png")
    plt.close(fig)

    from whisker.coil.thermal_network import ThermalNetwork

    net = ThermalNetwork(design)
    md = [
        "# Actuation: thermal guard and recording, measured",
        "",
        f"Machine: {machine_line()}. Default design: {design.coil.resistance:g} ohm coils, "
        f"{full_scale_voltage(design):.3f} V at the coil at 100 % duty ({design.driver.type}, "
        f"{design.driver.supply_voltage:g} V supply, whisker.coil.driver). The guard runs the thermal network "
        "(whisker.coil.thermal_network) and holds every material "
        f"drive.guard_margin = {design.drive.guard_margin:g} K below its own limit (the lowest limit: "
        f"{net.limit_label}; table B names the one that binds). "
        "Produced by `make bench` (benchmarks/bench_actuation.py).",
        "",
        "## A. The guard's winding estimate against its own model at a fine step, and the cheaper one-node model",
        "",
        "Profile: full level for 1.5 s, level 0.5 for 3 s, off for 3.5 s. The guard integrates with the "
        "level applied since its previous update (sub-steps of <= 50 ms, R(T) re-evaluated each). Reference: "
        f"the same network stepped at {REF_STEP_S * 1000:g} ms and {2 * REF_STEP_S * 1000:g} ms, Richardson-"
        "extrapolated, so the network rows measure the update period alone. The one-node row is the lumped coil "
        "model (whisker.coil.thermal.CoilThermal) as a guard at the watchdog's period: cheaper per update, "
        "and its error is a model error (it lumps the winding with the bobbin, rod and membrane). "
        "`most_under_K`: the largest underestimate (estimate below the reference), the unsafe direction.",
        "",
        markdown_table(a_rows, ["model", "update_period_s", "max_error_K", "most_under_K", "error_at_peak_K",
                                "us_per_update_8_coils", "cpu_share_pct"],
                       {"max_error_K": ".3g", "most_under_K": ".3g", "error_at_peak_K": ".3g",
                        "us_per_update_8_coils": ".0f",
                        "cpu_share_pct": ".2g"}),
        "",
        "![guard estimate](actuation_guard.png)",
        "",
        "## B. What the guard allows the paper's coil (policy cut vs derate, 300 s of continuous request)",
        "",
        "Default design (`driver.series_resistance` = auto = "
        f"{series_resistance_ohm(design):g} ohm in series with each coil) and the same design without the "
        "resistor (`driver.series_resistance=0`, PWM alone). `coil_W_cold` / `resistor_W_cold`: mean heat in "
        "the coil / its series resistor at that level, cold (20 C) coil; `model_time_to_margin_s`: the guard's "
        "model alone (the network, 10 ms steps, no cut) from ambient until the weakest material comes within "
        "the margin of its limit; `peak_winding_C`: the hottest the winding got (the winding's own limit, the "
        "enamel's, is far higher: the cut comes from the material named in `limited_by`).",
        "",
        markdown_table(b_rows, ["series_ohm", "full_scale_V", "drive", "level", "coil_W_cold", "resistor_W_cold",
                                "policy", "model_time_to_margin_s", "full_level_for_s", "mean_level_after_150s",
                                "peak_winding_C", "trips", "limited_by"],
                       {"full_scale_V": ".3f", "coil_W_cold": ".2f", "resistor_W_cold": ".2f",
                        "model_time_to_margin_s": ".2f", "full_level_for_s": ".2f",
                        "mean_level_after_150s": ".3f", "peak_winding_C": ".1f"}),
        "",
        "`full_level_for_s`: seconds at the requested level before the guard first reduces it "
        "(the guard, looking one 20 ms update ahead, cuts within one update of the model's time). "
        "`mean_level_after_150s`: the average level the guard allows once settled (derate: a steady level; "
        "cut: on/off cycling between the margin and the margin plus the hysteresis).",
        "",
        "## C. Recording cost per 640x480 frame (image + 8 track rows + guard row)",
        "",
        markdown_table(c_rows, ["image", "fsync", "ms_per_frame", "kB_per_frame", "max_fps"],
                       {"ms_per_frame": ".2f", "kB_per_frame": ".0f", "max_fps": ".0f"}),
        "",
        f"Encoding alone: PNG {t_png:.1f} ms, JPEG {t_jpg:.1f} ms per frame. fsync protects the rows and "
        "frames against a power cut; a SIGKILL loses nothing written either way (the page cache survives "
        "the process). Timings are best-of-5 on a shared machine.",
        "",
    ]
    write_text("actuation.md", "\n".join(md))
    print("\n".join(md))


if __name__ == "__main__":
    main()
