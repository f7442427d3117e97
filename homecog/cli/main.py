"""The ``homecog`` command: one module per command group, registered here.

Every command takes ``--home`` (a built-in name or a path) and ``--json``. Bad input
prints one line on stderr and exits with status 2; nothing is overwritten.
"""

from __future__ import annotations

import logging
import os
import sys

import typer

# Typer 0.29 carries its own copy of click; its exceptions live there (typer is pinned).
from typer._click import exceptions as click_errors

from homecog.cli import evaluate, fleet, home, knowledge, learn, plan, up
from homecog.cli.export import export_app
from homecog.cli.ha import ha_app
from homecog.cli.log import adapt_kasteren, log_app
from homecog.errors import HomecogError, one_line

app = typer.Typer(
    name="homecog",
    help="Service cognition for home service robots: learn which services a user needs.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
home_app = typer.Typer(help="Show or check home definitions.", no_args_is_help=True)
app.add_typer(home_app, name="home")
app.add_typer(ha_app, name="ha")
app.add_typer(log_app, name="log")
app.add_typer(export_app, name="export")
fleet_app = typer.Typer(help="Learn a fleet of homes into one database.", no_args_is_help=True)
app.add_typer(fleet_app, name="fleet")
fleet_app.command("train")(fleet.fleet_train)
home_app.command("show")(home.home_show)
home_app.command("check")(home.home_check)
app.command()(learn.train)
app.command()(learn.build)
app.command()(knowledge.cognize)
app.command()(knowledge.correct)
app.command("eval")(evaluate.eval_command)
app.command()(evaluate.replay)
app.command("adapt-mit")(evaluate.adapt_mit)
app.command("adapt-kasteren")(adapt_kasteren)
app.command()(plan.plan)
app.command()(plan.simulate)
app.command()(up.up)
app.command()(fleet.serve)


class _Notices(logging.Handler):
    """What a command does on its own (learns, builds), one line on stderr, whatever ``--json``."""

    def emit(self, record: logging.LogRecord) -> None:
        print(f"homecog: {record.getMessage()}", file=sys.stderr, flush=True)


def _say_notices() -> None:
    log = logging.getLogger("homecog.notice")
    if not any(isinstance(h, _Notices) for h in log.handlers):
        log.addHandler(_Notices())
    log.setLevel(logging.INFO)
    log.propagate = False


def main(argv: list[str] | None = None) -> int:
    """Run the command line; errors become one line on stderr and exit status 2."""
    args = sys.argv[1:] if argv is None else argv
    _say_notices()
    try:
        result = app(args=args, prog_name="homecog", standalone_mode=False)
    except HomecogError as e:
        print(f"homecog: error: {one_line(str(e))}", file=sys.stderr)
        return 2
    except click_errors.NoArgsIsHelpError:
        return 2  # the help was printed
    except click_errors.UsageError as e:
        where = f"{e.ctx.command_path}: " if e.ctx else ""
        print(f"homecog: error: {one_line(where + e.format_message())}", file=sys.stderr)
        return 2
    except typer.Abort:
        print("homecog: aborted", file=sys.stderr)
        return 130
    except KeyboardInterrupt:
        print("homecog: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 1
    return result if isinstance(result, int) else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
