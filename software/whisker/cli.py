"""`whisker`: the command line. Subcommands live in whisker/commands/<group>/<name>.py, one module each,
exposing a click command or group called `cli`; they are imported only when used, so
`whisker --help` stays fast and a heavy library (CadQuery, OpenCV, MuJoCo) loads only for its command.

Every failure leaves through one path (whisker.errors): one line on stderr naming what failed, the
path or value and what to do; exit status 2 for bad input, 1 for a fault of the environment.
`whisker --debug ...` or WHISKER_DEBUG=1 shows the traceback instead.
"""

from __future__ import annotations

import errno
import importlib

import click

from whisker import __version__, commands


def _command_path(group: click.Group, ctx: click.Context, tokens: list[str]) -> str:
    """'whisker classify train' from the tokens left after the group's own options."""
    names, cmd = ["whisker"], group
    for tok in tokens:
        if not isinstance(cmd, click.Group) or tok.startswith("-"):
            break
        try:
            sub = cmd.get_command(ctx, tok)
        except Exception:  # an import error in a command module: name what we have
            sub = None
        if sub is None:
            break
        names.append(tok)
        cmd = sub
    return " ".join(names)


class LazyGroup(click.Group):
    def list_commands(self, ctx):
        return sorted(commands.command_modules())

    def get_command(self, ctx, name):
        if name not in self.list_commands(ctx):
            return None
        from whisker.cliutil import harden_numbers

        return harden_numbers(importlib.import_module(commands.command_modules()[name]).cli)

    def invoke(self, ctx):
        from whisker.errors import debug_requested, explain

        protected = ctx.__dict__.get("_protected_args", ctx.__dict__.get("protected_args", []))
        tokens = [*protected, *ctx.args]
        try:
            return super().invoke(ctx)
        except (click.exceptions.ClickException, click.exceptions.Exit, click.exceptions.Abort):
            raise
        except Exception as err:
            if ctx.params.get("debug") or debug_requested():
                raise
            if isinstance(err, OSError) and err.errno == errno.EPIPE:
                raise                    # the reader went away (| head): click exits quietly
            if isinstance(err, ModuleNotFoundError):
                # A library from an extra that is not installed: one line naming the pip install, exit 1.
                from whisker.extras import missing_extra_message

                message = missing_extra_message(err, f"whisker {ctx.invoked_subcommand or ''}".strip())
                if message is not None:
                    click.echo(message, err=True)
                    ctx.exit(1)
            code, line = explain(err)
            click.echo(f"{_command_path(self, ctx, tokens)}: {line}", err=True)
            ctx.exit(code)


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="whisker")
@click.option("--debug", is_flag=True, help="Show the Python traceback of a failure (also: WHISKER_DEBUG=1).")
def main(debug):
    """Whisker-array tactile sensor: CAD, calculators and sensor software.

    Every command reads one design (default: hw/sensor.toml, the paper's sensor); change any value
    with --design FILE and --set section.key=value. Units: mm, g, s, V, A, ohm, deg, C.

    Errors: one line on stderr; exit status 2 = bad input, 1 = a fault of the environment (disk
    full, read-only folder, no camera); --debug shows the traceback.
    """


if __name__ == "__main__":
    main()
