"""`whisker locate`: where along a whisker the object touches it, by active whisking (docs/locate.md)."""

from __future__ import annotations

from pathlib import Path

import click

from whisker.cliutil import design_options, fail


@click.command()
@design_options
@click.argument("session", required=False, type=click.Path(file_okay=False))
@click.option("--whisker", "whisker", type=click.IntRange(0), default=0, show_default=True,
              help="Index of the whisker that touches the object and was swept.")
@click.option("--simulate", "simulate_mm", type=click.FloatRange(1, 200), default=None, metavar="MM",
              help="No recording: simulate a sweep against an object touching the rod MM mm from the pivot, "
                   "render the camera frames and track them (whisker.sim.experiments.locate_sweep).")
@click.option("--material", default=None, help="--simulate: the object's material in sim/scenes/materials.toml "
                                                 "(default: rigid).")
@click.option("--approach-deg", type=click.FloatRange(-89, 89), default=0.0, show_default=True,
              help="--simulate: angle between the object's surface normal and the sweep axis, deg.")
@click.option("--amplitude", type=click.FloatRange(-1, 1), default=None,
              help="Sweep level (signed PWM duty, + retracts) [default: whisker.sensing.locate.DEFAULT_AMPLITUDE].")
@click.option("--duration", "duration_s", type=click.FloatRange(0.05, 60), default=None,
              help="Sweep duration, s [default: DEFAULT_DURATION_S].")
@click.option("--fps", type=click.FloatRange(1, 1000), default=120.0, show_default=True,
              help="--simulate: camera frame rate, frames/s.")
@click.option("--start-temperature", "start_C", type=click.FloatRange(-50, 200), default=None,
              help="Coil temperature before the sweep, C (default: the design's ambient); the sweep is refused "
                   "if it would pass the thermal guard's cut-off.")
@click.option("--unknown-compliance", is_flag=True, default=False,
              help="The object may be soft and its compliance is unknown: report an upper bound on the distance "
                   "(mm; a soft object only looks farther) instead of a distance.")
@click.option("--mu", type=click.FloatRange(0, 10), default=None,
              help="Opt-in: Coulomb coefficient of the rod on the object (the simulator's contact.rod_friction is "
                   "0.3), to locate a contact that slides every cycle at its friction cone's edge; needs the absolute "
                   "tilt to ~1e-5 rad (docs/locate.md). Without it such a contact gets \"slip\".")
@click.option("--out", type=click.Path(file_okay=False), default=None,
              help="Folder for locate.md (table), locate.csv and locate.png (tilt vs commanded torque).")
def cli(design, session, whisker, simulate_mm, material, approach_deg, amplitude, duration_s, fps, start_C,
        unknown_compliance, mu, out):
    """Estimate the contact distance along the rod (mm from the pivot) and the contact force (mN) from a
    sweep of the coil's torque (N*mm) against the tracked base tilt (rad): Kaneko's active antenna,
    K = k + 3 EI / r. SESSION is a folder written by `whisker record` whose actuation swept the whisker
    while it touched the object; or give --simulate MM. A whisker that moves freely gets "no contact",
    a recording whose levels never change is refused, a sweep past the thermal limit is refused.

    \b
      whisker locate --simulate 35 --out runs/locate
      whisker locate runs/sweep-1 --whisker 3 --out runs/locate
    """
    import numpy as np

    from whisker.sensing import locate as L

    amplitude = L.DEFAULT_AMPLITUDE if amplitude is None else amplitude
    duration_s = L.DEFAULT_DURATION_S if duration_s is None else duration_s
    if (session is None) == (simulate_mm is None):
        fail("locate: give a recorded SESSION folder or --simulate MM (one of them)")
    if whisker >= design.whiskers.count:
        fail(f"locate: --whisker {whisker} but the design has {design.whiskers.count} whiskers (0..{design.whiskers.count - 1})")
    try:
        if simulate_mm is not None:
            from whisker.sim.experiments import locate_sweep as S

            heat = L.check_sweep(design, amplitude, duration_s, start_C)
            if simulate_mm > design.whiskers.protrusion:
                fail(f"locate: --simulate {simulate_mm:g} mm is beyond the rod's {design.whiskers.protrusion:g} mm")
            case = S.Case(simulate_mm, material, approach_deg)
            t, lev = L.sweep_levels(amplitude, duration_s, fps)
            tilt = S.sweep_tilt(design, case, lev)
            with click.progressbar(length=len(t), label="rendering and tracking", file=None) as bar:
                last = [0]

                def progress(frac):
                    bar.update(int(frac * len(t)) - last[0])
                    last[0] = int(frac * len(t))
                obs = S.render_and_track(design, whisker, tilt, progress=progress)
            sweep = L.Sweep(t, lev, obs)
            source = f"simulated: contact at {simulate_mm:g} mm, {material or 'rigid'}, approach {approach_deg:g} deg"
        else:
            sweep, heat = _from_session(design, session, whisker), None
            source = f"{session}, whisker {whisker}"
        res = L.estimate(design, sweep, rigid_object=not unknown_compliance, mu=mu)
    except L.LocateError as err:
        fail(f"locate refused: {err}")
    row = {"source": source, **res.row()}
    if heat:
        row.update(sweep_level=amplitude, sweep_s=duration_s, coil_rise_K=round(heat["rise_K"], 2))
    click.echo(f"{res.status}: {res.message}")
    if out:
        _write(Path(out), design, sweep, res, row)
        click.echo(f"-> {out}/locate.md, locate.csv, locate.png", err=True)


def _from_session(design, folder, whisker):
    """Sweep of one whisker from a `whisker record` session: tracked tips -> tilt, applied levels per frame."""
    import numpy as np

    from whisker.data.recording import RecordingError
    from whisker.data.session import load_session
    from whisker.sensing import locate as L

    try:
        s = load_session(folder)
    except RecordingError as err:
        raise L.LocateError(str(err)) from None
    if not s.tracks or "tip_x_mm" not in s.tracks:
        raise L.LocateError(f"{folder}: no tracks in the recording (record with tracking on, or run `whisker track`)")
    if len(s.act_time_s) == 0:
        raise L.LocateError(f"{folder}: recording without actuation (no actuation.csv rows); locate needs a sweep")
    idx = np.searchsorted(s.act_time_s, s.frame_time_s, side="right") - 1
    lev = np.where(idx >= 0, s.act_applied[np.clip(idx, 0, None), whisker], 0.0)
    tip = np.stack([s.tracks["tip_x_mm"][:, whisker], s.tracks["tip_y_mm"][:, whisker]], axis=1)
    valid = s.tracks["valid"][:, whisker] > 0
    tilt = L.tilt_from_tip_mm(design, whisker, np.nan_to_num(tip))
    return L.Sweep(s.frame_time_s, lev, tilt, valid & np.isfinite(tip).all(axis=1))


def _write(out: Path, design, sweep, res, row) -> None:
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from whisker.files import atomic_write_bytes, atomic_write_text
    from whisker.sensing import locate as L

    keys = list(row)
    atomic_write_text(out / "locate.csv", ",".join(keys) + "\n" + ",".join(f'"{row[k]}"' if isinstance(row[k], str)
                                                                           else str(row[k]) for k in keys) + "\n")
    md = ["| quantity | value |", "|---|---|"] + [f"| {k} | {row[k]} |" for k in keys]
    atomic_write_text(out / "locate.md", "# whisker locate\n\n" + "\n".join(md) + "\n")
    ok = np.isfinite(sweep.tilt_rad).all(axis=1)
    tau = L.coil_torque_Nmm(design, sweep.level[ok], sweep.tilt_rad[ok, 0])
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(tau, 1e3 * sweep.tilt_rad[ok, 0], ".", ms=3, label="tracked radial tilt")
    ax.plot(tau, 1e3 * sweep.tilt_rad[ok, 1], ".", ms=3, alpha=0.5, label="tracked tangential tilt")
    if res.stiffness_Nmm_per_rad:
        x = np.linspace(tau.min(), tau.max(), 2)
        a = np.median(sweep.tilt_rad[ok, 0] - tau / res.stiffness_Nmm_per_rad)
        ax.plot(x, 1e3 * (a + x / res.stiffness_Nmm_per_rad), "k-", label=f"K = {res.stiffness_Nmm_per_rad:.0f} N*mm/rad")
    ax.set_xlabel("commanded coil torque (N*mm)")
    ax.set_ylabel("base tilt (mrad)")
    ax.set_title(f"{res.status}: {res.message}"[:90], fontsize=8)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(out / "locate.png", buf.getvalue())
