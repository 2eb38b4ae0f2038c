"""One command line (issue 30): every command that reads the design takes --design and --set, one
name per concept, help on every option, and two writers to one --out are refused."""

from __future__ import annotations

import click
import pytest

from whisker.cli import main

#: commands that do not read a design at all (none today: even `doctor` checks the design's pins)
NO_DESIGN: set[tuple[str, ...]] = set()


def leaves(cmd=main, path=()):
    ctx = click.Context(main)
    if isinstance(cmd, click.Group):
        for name in cmd.list_commands(ctx):
            yield from leaves(cmd.get_command(ctx, name), path + (name,))
    else:
        yield path, cmd


def _opts(cmd):
    return {o for p in cmd.params if isinstance(p, click.Option) for o in p.opts}


def test_every_command_that_reads_the_design_takes_design_and_set():
    missing = [" ".join(p) for p, c in leaves() if p not in NO_DESIGN and not {"--design", "--set"} <= _opts(c)]
    assert not missing, f"commands without --design/--set: {missing}"


def test_one_name_per_concept():
    """The tracker is --tracker, the state estimator --estimator, the input build folder --build, the
    output --out: no command uses --method (it meant both) and --out is never an input."""
    for path, cmd in leaves():
        opts = _opts(cmd)
        assert "--method" not in opts, " ".join(path)
        for p in cmd.params:
            if isinstance(p, click.Option) and "--tracker" in p.opts:
                assert set(p.type.choices) >= {"roi", "paper"}, path
            if isinstance(p, click.Option) and "--estimator" in p.opts:
                assert set(p.type.choices) == {"authors", "adaptive"}, path
            if isinstance(p, click.Option) and "--build" in p.opts:
                assert "Build folder" in p.help, path
            if isinstance(p, click.Option) and "--out" in p.opts:
                assert "Build folder" not in (p.help or ""), path


def test_help_on_every_option():
    bare = [f"{' '.join(path)} {p.opts[0]}" for path, cmd in leaves() for p in cmd.params
            if isinstance(p, click.Option) and not p.hidden and p.name != "help" and not (p.help or "").strip()]
    assert not bare, f"options without help: {bare}"


@pytest.mark.parametrize("argv,out_kind", [
    (["calibrate", "board", "--out", "{out}"], "dir"),
    (["classify", "train", "--data", "{nowhere}", "--out", "{out}"], "file"),
    (["hw", "bom", "--out", "{out}"], "file"),
    (["cad", "sweep", "--counts", "8", "--radii", "12", "--out", "{out}"], "dir"),
    (["sim", "angle_vs_voltage", "--out", "{out}", "-q"], "dir"),
])
def test_a_second_writer_to_one_out_is_refused(tmp_path, argv, out_kind):
    """While one run holds --out (whisker.files.output_lock, as a first run does), a second is
    refused at once with one line naming the output."""
    from click.testing import CliRunner

    from whisker.files import output_lock

    out = tmp_path / ("o" if out_kind == "dir" else "o.bin")
    args = [a.format(out=out, nowhere=tmp_path / "nowhere") for a in argv]
    with output_lock(out):
        res = CliRunner().invoke(main, args)
    assert res.exit_code == 1, res.output
    lines = [x for x in res.output.splitlines() if "being written by another run" in x]
    assert len(lines) == 1 and str(out) in lines[0], res.output


def test_design_show_prints_units():
    from conftest import run_cli

    res = run_cli("design", "show")
    assert res.returncode == 0, res.stderr
    line = {ln.split("=")[0].strip(): ln for ln in res.stdout.splitlines() if "=" in ln and not ln.startswith("#")}
    for key, unit in (("ring_radius", "# mm;"), ("remanence", "# T;"), ("voltage", "# V;"),
                      ("resistance", "# ohm"), ("convection_coefficient", "# W/(m^2 K);"),
                      ("rotational_stiffness", "# N*mm/rad;"), ("max_deflection_deg", "# deg;")):
        assert unit in line[key], line[key]


def test_actuate_on_the_simulator_prints_the_tilt():
    from conftest import run_cli

    res = run_cli("actuate", "--backend", "sim", "retract", "--duration", "0.6")
    assert res.returncode == 0, res.stderr
    line = next(ln for ln in res.stderr.splitlines() if ln.startswith("simulated tilt"))
    peak = [float(x) for x in line.split("largest reached: [")[1].rstrip("]").split(",")]
    assert len(peak) == 8 and all(5.0 < p < 20.0 for p in peak), line      # retracted, within the stop


def test_explore_plot_labels_every_design_even_when_two_coincide():
    """Two designs on one point (same coil power, same success) were drawn as one unlabelled point:
    now the point says it holds both."""
    import io

    from PIL import Image

    from whisker.explore import report

    rows = [{"point": i, "status": "ok", "design_digest": f"d{i}", "whiskers.count": n, "coil_power_W": 1.53,
             "grasp_all_pct": 40.0, "grasp_all_lo": 30.0, "grasp_all_hi": 50.0} for i, n in enumerate((6, 8))]
    texts = []
    import matplotlib.axes

    orig = matplotlib.axes.Axes.annotate

    def spy(self, text, *a, **kw):
        texts.append(text)
        return orig(self, text, *a, **kw)

    matplotlib.axes.Axes.annotate = spy
    try:
        png = report.plot_front(rows, report.pareto(rows, "coil_power_W"), "coil_power_W", "coil power (W)",
                                ["whiskers.count"])
    finally:
        matplotlib.axes.Axes.annotate = orig
    assert any("2 designs" in t and "count=6" in t and "count=8" in t for t in texts), texts
    assert Image.open(io.BytesIO(png)).size[0] > 500
