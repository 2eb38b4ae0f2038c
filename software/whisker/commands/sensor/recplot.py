"""`whisker recplot`: the paper's Fig. 8 from recorded trials (displacement vs time, mean and band)."""

from __future__ import annotations

import click

from whisker.cliutil import fail


@click.command()
@click.argument("sessions", nargs=-1, required=True, type=click.Path(file_okay=False, exists=True))
@click.option("--out", required=True, type=click.Path(dir_okay=False),
              help="Figure file (.png, .pdf or .svg); the curves go beside it as .csv.")
@click.option("--quantity", type=click.Choice(["px", "mm", "deg"]), default="px", show_default=True,
              help="px: marker displacement (as the paper); mm: tip displacement; deg: tilt.")
@click.option("--band", type=click.Choice(["std", "sem", "minmax"]), default="std", show_default=True,
              help="Error band across trials.")
@click.option("--align", default="retract", show_default=True,
              help="Actuation phase whose first command is time 0 in every trial (retract, hold, release ...), "
                   "or 'frame' to align on each trial's first frame. A trial without that command is refused, "
                   "named.")
@click.option("--dt", "dt_s", type=click.FloatRange(0, 3600, min_open=True), default=None,
              help="Time step of the common grid, s (default: frame interval).")
@click.option("--grid", is_flag=True, help="One panel per whisker instead of one axes.")
@click.option("--title", default="", help="Figure title.")
@click.option("--design", "design_file", type=click.Path(dir_okay=False), default=None,
              help="Design TOML file the sessions must have been recorded with (default: each session's own "
                   "recorded design, from its metadata.json).")
@click.option("--set", "overrides", multiple=True, metavar="SECTION.KEY=VALUE",
              help="Override one value of that design, e.g. --set whiskers.count=6 (repeatable).")
def cli(sessions, out, quantity, band, align, dt_s, grid, title, design_file, overrides):
    """Plot each whisker's displacement against time, mean and error band across the trial SESSIONS
    (folders written by `whisker record`), with the phases marked: (1) retract, (2) hold / arm up,
    (3) release (the paper's Fig. 8). Example:

    \b
      whisker recplot runs/foam-ball-* --out docs/img/fig8_foam_ball.png --title "foam ball"
    """
    from pathlib import Path

    from whisker.files import atomic_write_text
    from whisker.data.recording import RecordingError
    from whisker.data.recplot import fig8_csv, fig8_data, load_sessions, plot_fig8

    from whisker.cliutil import check_out_path

    check_out_path(out, "recplot")
    try:
        loaded = load_sessions(sessions)
        if design_file is not None or overrides:
            from whisker.design import DesignError, load_design

            try:
                d = load_design(design_file, overrides)
            except DesignError as err:
                fail(f"design refused: {err}")
            other = [str(s.folder) for s in loaded if s.meta.get("digest") != d.digest()]
            if other:
                fail(f"recplot: {len(other)} session(s) were recorded with another design than {d.digest()}: "
                     f"{', '.join(other[:3])}; leave --design/--set out to plot each with its own")
        data = fig8_data(loaded, quantity=quantity, align=align, dt_s=dt_s, band=band)
    except (RecordingError, ValueError) as err:
        fail(f"recplot: {err}")
    try:
        plot_fig8(data, out, title=title, grid=grid)
        atomic_write_text(Path(out).with_suffix(".csv"), fig8_csv(data))
    except OSError as err:
        fail(f"recplot: cannot write the figure {out}: {err.strerror or err}", code=1)
    click.echo(f"{out}: {data.trials} trial(s), {len(data.t_s)} time steps, phases at "
               + ", ".join(f"{p} {t:.2f} s" for p, t in data.phases.items()), err=True)
