"""`whisker`: the command line. Subcommands live in whisker/commands/<name>.py, one module each,
exposing a click command or group called `cli`; they are imported only when used, so
`whisker --help` stays fast and a heavy library (CadQuery, OpenCV, MuJoCo) loads only for its command.
"""

from __future__ import annotations

import importlib
import pkgutil

import click

from whisker import __version__, commands


class LazyGroup(click.Group):
    def list_commands(self, ctx):
        return sorted(m.name for m in pkgutil.iter_modules(commands.__path__) if not m.name.startswith("_"))

    def get_command(self, ctx, name):
        if name not in self.list_commands(ctx):
            return None
        return importlib.import_module(f"whisker.commands.{name}").cli

    def invoke(self, ctx):
        # A library from an extra that is not installed: one line naming the pip install, exit 1.
        try:
            return super().invoke(ctx)
        except ModuleNotFoundError as err:
            from whisker.extras import missing_extra_message

            message = missing_extra_message(err, f"whisker {ctx.invoked_subcommand or ''}".strip())
            if message is None:
                raise
            click.echo(message, err=True)
            ctx.exit(1)


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="whisker")
def main():
    """Whisker-array tactile sensor: CAD, calculators and sensor software.

    Every command reads one design (default: hw/sensor.toml, the paper's sensor); change any value
    with --design FILE and --set section.key=value. Units: mm, g, s, V, A, ohm, deg, C.
    """


if __name__ == "__main__":
    main()
