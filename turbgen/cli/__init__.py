"""turbgen command line: click commands only (parse, call the library, print).

Library errors (``turbgen.errors.TurbgenError``) become one line on stderr, run fields spelled as options
(:func:`as_options`), exit code by class (EXIT_CODES). Each sub-module holds one command or group, listed
in COMMANDS and imported on use."""

from __future__ import annotations

import gc
import importlib
import logging
import os
import re
import signal
import sys
import warnings
from contextlib import contextmanager

import click

from turbgen import interruption
from turbgen.version import __version__
from turbgen.errors import ParameterError, StoreError, TurbgenError
from turbgen.spec.models import DECLARATIONS


# click >= 8.2 raises this (a UsageError) to print the help of a group called without a command
_NoArgsIsHelp = getattr(click.exceptions, "NoArgsIsHelpError", ())


class UserError(click.ClickException):
    """A usage error from the library: printed as one line, exit code 2 (or ``exit_code``)."""

    exit_code = 2

    def __init__(self, message: str, exit_code: int = 2):
        super().__init__(message)
        self.exit_code = exit_code

    def show(self, file=None):
        click.echo(f"Error: {self.format_message()}", err=True)


# exit code per error class (the first class the error is an instance of); every user error is 2
EXIT_CODES = {StoreError: 2, ParameterError: 2, TurbgenError: 2}
# run fields whose option is not --<field with - for _>
_OPTIONS = {"chunk_t": "--chunks", "dt_s": "--dt", "dy_m": "--dy", "dz_m": "--dz", "x_m": "--planes",
            "U_m_s": "--U", "hub_height_m": "--hub-height", "memory_bytes": "--memory", "a_yz": "--ayz",
            "lc_m": "--lc"}  # fmt: skip


def as_options(message: str) -> str:
    """A library message with its backquoted run fields spelled as options: "lower `pad_yz`" -> "lower --pad-yz"."""
    return re.sub(r"`(\w+)`", lambda m: _OPTIONS.get(m[1], "--" + m[1].replace("_", "-")), message)


def user_error(exc: TurbgenError) -> UserError:
    """The one-line CLI error of a library error (options spelled for the command line, exit code by class)."""
    code = next(code for cls, code in EXIT_CODES.items() if isinstance(exc, cls))
    return UserError(as_options(str(exc)), code)


# set by main(), the console script (run_imports)
_console_script = False

# command name -> (module, attribute), imported only when the command runs (or for --help); a model's command is
# declared with the model (turbgen.spec.models), else turbgen.cli.model builds it
COMMANDS = {
    **{d.name: tuple((d.command or "turbgen.cli.model:model_command").split(":")) for d in DECLARATIONS},
    "export": ("turbgen.cli.export", "export"),
    "fit": ("turbgen.cli.theory", "fit"),
    "info": ("turbgen.cli.info", "info"),
    "lidar": ("turbgen.cli.lidar", "lidar"),
    "serve": ("turbgen.cli.serve", "serve"),
    "sweep": ("turbgen.cli.sweep", "sweep"),
    "theory": ("turbgen.cli.theory", "theory"),
    "transient": ("turbgen.cli.transient", "transient"),
    "validate": ("turbgen.cli.validate", "validate"),
}
# each command's line in `turbgen --help`, listed without importing the commands (slow); their short help is set here
SUMMARIES = {
    **{d.name: d.summary for d in DECLARATIONS},
    "export": "Write a store as OpenFAST, HAWC2 or lidar-simulator files.",
    "fit": "Fit the Mann model to data (fit mann DATA), or Kaimal to Mann.",
    "info": "Summarise a store: model, grid, parameters, size, completeness.",
    "lidar": "Virtual lidar on a store, its preview theory, the optimizer.",
    "serve": "Serve fields over HTTP: a job service with a web page.",
    "sweep": "Generate every field of a sweep on dask (resumable).",
    "theory": "Evaluate model spectra and coherences (Mann, space-time, Kaimal).",
    "transient": "Write an IEC 61400-1 transient (EOG, EDC, ECD, EWS) wind file.",
    "validate": "Validate a store against its model's theory: PASS or FAIL.",
}


class TurbgenGroup(click.Group):
    """A click group with lazily imported commands that turns ParameterError into a one-line usage error."""

    def list_commands(self, ctx):
        return sorted(COMMANDS)

    def get_command(self, ctx, cmd_name):
        if cmd_name not in COMMANDS:
            return None
        module, attr = COMMANDS[cmd_name]
        with run_imports():
            command = getattr(importlib.import_module(module), attr)
        if not isinstance(command, click.Command):  # turbgen.cli.model's factory
            command = command(cmd_name)
        command.short_help = SUMMARIES[cmd_name]
        return command

    def format_commands(self, ctx, formatter):
        """The commands and their SUMMARIES, none imported."""
        with formatter.section("Commands"):
            formatter.write_dl([(name, SUMMARIES[name]) for name in self.list_commands(ctx)])

    def make_context(self, info_name, args, parent=None, **extra):
        try:
            return super().make_context(info_name, args, parent=parent, **extra)
        except click.ClickException as exc:  # e.g. `turbgen --bogus`
            raise _one_line(exc) from None

    def invoke(self, ctx):
        interruption.forget_signals()  # an earlier command in this process (tests) is not this one
        try:
            return self._invoke_one_line(ctx)
        except (click.exceptions.Exit, click.ClickException):  # already said (e.g. Ctrl-C's line) or a user error
            raise
        except Exception:  # a signal whose exception the running library replaced by its own error
            sig = interruption.received_signal()
            if sig is None:
                raise
            _say_stopped(ctx, sig)
            ctx.exit(128 + sig)

    def _invoke_one_line(self, ctx):
        try:
            return super().invoke(ctx)
        except TurbgenError as exc:
            if interruption.received_signal() is not None:  # the library's error for our signal (a write stopped)
                raise
            raise user_error(exc) from None
        except click.ClickException as exc:  # click's own usage errors (bad option, missing argument, ...)
            raise _one_line(exc) from None
        except KeyboardInterrupt:  # Ctrl-C: writers have removed their temporaries; conventional exit 130
            _say_stopped(ctx, signal.SIGINT)
            ctx.exit(130)
        except SystemExit as exc:  # SIGTERM / SIGHUP turned into SystemExit(128 + signum) by the writers
            if exc.code in (128 + signal.SIGTERM, 128 + signal.SIGHUP):
                _say_stopped(ctx, exc.code - 128)
            raise
        except OSError as exc:  # a file-system error the library did not word itself (read-only, missing dir)
            if interruption.received_signal() is not None:  # or a library's own error for our signal (a timeout)
                raise
            where = f"{exc.filename}: " if exc.filename else ""
            raise UserError(f"{where}{exc.strerror or type(exc).__name__} (errno {exc.errno})") from None


# commands whose outputs are written under temporary names that an interruption removes (others write nothing,
# or only plots, and must not claim a removal)
PUBLISHING_COMMANDS = (*(d.name for d in DECLARATIONS), "export", "sweep")


def _say_stopped(ctx, sig: int) -> None:
    """Print the one line of a command stopped by signal ``sig``, without warnings about zarr reads submitted but never
    run; it says unfinished output was removed only for a command that writes its output under temporary names
    (PUBLISHING_COMMANDS)."""
    warnings.filterwarnings("ignore", message="coroutine .* was never awaited", category=RuntimeWarning)
    logging.getLogger("asyncio").setLevel(logging.CRITICAL)  # "Task was destroyed but it is pending!" at exit
    what = "interrupted" if sig == signal.SIGINT else f"terminated ({signal.Signals(sig).name})"
    removed = ctx.invoked_subcommand in PUBLISHING_COMMANDS
    click.echo(f"Error: {what}" + ("; unfinished output was removed" if removed else ""), err=True)


def _one_line(exc: click.ClickException) -> click.ClickException:
    """Click's exception as one line (no usage block, no 'Try --help' hint), exit code 2."""
    if isinstance(exc, (UserError, _NoArgsIsHelp)):  # a bare `turbgen` / `turbgen theory` shows the help
        return exc
    message = " ".join(exc.format_message().split())
    ctx = getattr(exc, "ctx", None)
    if isinstance(exc, click.UsageError) and ctx is not None and ctx.command_path:
        message = f"{ctx.command_path}: {message}"
    return UserError(message)


@click.group(cls=TurbgenGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="turbgen")
@click.pass_context
def cli(ctx):
    """4D stochastic wind-turbulence fields for aeroelastic and lidar studies."""
    if ctx.invoked_subcommand != "serve":  # the service's server keeps its own signal handlers
        # interruption handling is the application's: for the command's duration SIGTERM/SIGHUP become SystemExit,
        # Ctrl-C KeyboardInterrupt, and the library's writers are told not to publish (turbgen.interruption)
        ctx.with_resource(interruption.exit_on_signals())


@contextmanager
def run_imports():
    """Around the imports of a command (get_command) or of its work (in the command, so --help and usage errors skip
    them): in the console script pyfftw first and lean, the cyclic collector paused, then the ~10^6 objects, as
    long-lived as the process, frozen out of it (gc.freeze)."""
    if not _console_script or not gc.isenabled():
        yield
        return
    _import_pyfftw_lean()
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        gc.enable()


def _import_pyfftw_lean() -> None:
    """Import pyfftw without its optional dask interface (dask.array and pandas: start-up and memory turbgen never
    uses) for this command's process only: that import fails fast while pyfftw loads, and works again after."""
    if "pyfftw" in sys.modules or "dask.array.fft" in sys.modules:
        return
    sys.modules["dask.array.fft"] = None  # pyfftw's `from dask.array.fft import ...` raises ImportError at once
    try:
        import pyfftw  # noqa: F401
    except ImportError:
        pass
    finally:
        del sys.modules["dask.array.fft"]


def main():
    """Console-script entry point (its imports are frozen out of the cyclic collector: run_imports)."""
    global _console_script
    # turbgen parallelises with its own thread pools: OpenBLAS threads would only oversubscribe the cores (set before
    # numpy loads OpenBLAS; a user's own setting is kept). The fields keep their bits (OpenBLAS does not split sums)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    _console_script = True
    cli()
