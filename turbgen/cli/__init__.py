"""turbgen command line: click commands only (parse, call the library, print).

User mistakes (``turbgen.errors.ParameterError``) become one line on stderr and exit code 2.
Each sub-module holds one command or command group and is registered below.
"""

from __future__ import annotations

import click

from turbgen import __version__
from turbgen.errors import ParameterError


class UserError(click.ClickException):
    """A usage error from the library: printed as one line, exit code 2."""

    exit_code = 2

    def show(self, file=None):
        click.echo(f"Error: {self.format_message()}", err=True)


class TurbgenGroup(click.Group):
    """A click group that turns ParameterError into a one-line usage error."""

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


def _register():
    from turbgen.cli import theory

    for command in (theory.theory, theory.fit):
        cli.add_command(command)

    from turbgen.cli import info

    cli.add_command(info.info)

    from turbgen.cli import export

    cli.add_command(export.export)

    from turbgen.cli import mann

    cli.add_command(mann.mann)

    from turbgen.cli import sweep

    cli.add_command(sweep.sweep)

    from turbgen.cli import kaimal

    cli.add_command(kaimal.kaimal)

    from turbgen.cli import validate

    cli.add_command(validate.validate)


_register()
