"""The ``sdc`` command line: one module per command, the group here.

Exit codes: 0 done (a collision is an outcome, not an error); 1 a run errored;
2 bad input (the message names the field or the file); 130 interrupted.
"""

from __future__ import annotations

import sys

import click

from scenarios.common.errors import SdcError
from scenarios.scene.compiled_kernels import kernel_choice
from sdc.cli import demo, estimate, export, replay, report, run, search, settle, sweep
from sdc.cli.common import EXIT_INTERRUPTED, bad_input


class _Cli(click.Group):
    """The command group, with one error prefix: click's own usage errors (a missing
    option, a bad choice) print ``error: ...`` as sdc's do, not ``Error: ...``, with the
    same exit codes (2 bad input; 130 interrupted)."""

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True,
             **extra):
        try:
            return super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except click.Abort:  # Ctrl-C where no command catches it
            click.echo("error: interrupted", err=True)
            sys.exit(EXIT_INTERRUPTED)
        except click.ClickException as e:
            context = getattr(e, "ctx", None)
            if context is not None:
                click.echo(context.get_usage(), err=True)
                click.echo(f"Try '{context.command_path} {context.help_option_names[0]}' "
                           "for help.\n", err=True)
            click.echo(f"error: {e.format_message()}", err=True)
            sys.exit(e.exit_code)


@click.group(cls=_Cli, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="sdc")
def main() -> None:
    """sdc: traffic-scale scenario simulator for a lidar avoid-then-return maneuver.

    Exit codes: 0 done (a collision is an outcome), 1 a run errored,
    2 bad input, 130 interrupted.
    """
    try:
        kernel_choice()  # checked before any command imports the kernels
    except SdcError as e:
        bad_input(str(e))


for _command in (run.run, demo.demo, settle.settle, report.report, sweep.sweep, search.search,
                 estimate.estimate, replay.replay, export.export):
    main.add_command(_command)
