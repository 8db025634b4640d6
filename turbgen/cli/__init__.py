"""turbgen command line: click commands only (parse, call the library, print).

User mistakes (``turbgen.errors.ParameterError``) become one line on stderr and exit code 2.
Each sub-module holds one command or command group, listed in COMMANDS and imported on use.
"""

from __future__ import annotations

import importlib

import click

from turbgen import __version__
from turbgen.errors import ParameterError


class UserError(click.ClickException):
    """A usage error from the library: printed as one line, exit code 2."""

    exit_code = 2

    def show(self, file=None):
        click.echo(f"Error: {self.format_message()}", err=True)


# command name -> (module, attribute); modules are imported only when their command runs (or for --help),
# so `turbgen info` does not pay for importing the FFT and synthesis stack
COMMANDS = {
    "export": ("turbgen.cli.export", "export"),
    "fit": ("turbgen.cli.theory", "fit"),
    "info": ("turbgen.cli.info", "info"),
    "kaimal": ("turbgen.cli.kaimal", "kaimal"),
    "mann": ("turbgen.cli.mann", "mann"),
    "sweep": ("turbgen.cli.sweep", "sweep"),
    "theory": ("turbgen.cli.theory", "theory"),
    "validate": ("turbgen.cli.validate", "validate"),
}


class TurbgenGroup(click.Group):
    """A click group with lazily imported commands that turns ParameterError into a one-line usage error."""

    def list_commands(self, ctx):
        return sorted(COMMANDS)

    def get_command(self, ctx, cmd_name):
        if cmd_name not in COMMANDS:
            return None
        module, attr = COMMANDS[cmd_name]
        return getattr(importlib.import_module(module), attr)

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except ParameterError as exc:
            raise UserError(str(exc)) from None


@click.group(cls=TurbgenGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="turbgen")
def cli():
    """4D stochastic wind-turbulence fields for aeroelastic and lidar studies."""


def main():
    """Console-script entry point."""
    cli()
