"""Command-line options more than one command declares: each is declared here, once.

Commands import this module and :mod:`rac.commands.common`, never each other.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from typing import Any

from rac.commands.common import CommandParser, run_values
from rac.errors import RacError
from rac.runtime.guardian import DEFAULT_GONE_S

# -- observations: --obs, --obs-file (diagnose, repair, diagram) ------------------------------


class _InOrder(argparse.Action):
    """Keep --obs and --obs-file in command-line order: later literals win (Algorithm 10).

    Appends in place (O(1)): copying the list at each use, as argparse's ``append`` does,
    is quadratic in the number of uses.  A batched run (``--obs-run``, see
    :class:`~rac.commands.common.CommandParser`) adds each of its literals.
    """

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        sources = getattr(namespace, "sources", None)
        if sources is None:  # a fresh list per parse, never the shared default
            sources = namespace.sources = []
        if self.dest == "obs_run":
            sources.extend(("obs", value) for value in run_values(values))
        else:
            sources.append((self.dest, values))


def add_observation_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--obs",
        metavar="LIT",
        action=_InOrder,
        help="an observed literal: 'ok(pose)', 'not ok(pose)', 'not_ok(pose)' (repeatable)",
    )
    parser.add_argument(
        "--obs-file",
        metavar="F",
        action=_InOrder,
        help="a file with one literal per line, '#' comments (repeatable)",
    )
    if isinstance(parser, CommandParser):
        parser.add_argument("--obs-run", action=_InOrder, help=argparse.SUPPRESS)
        parser.batch("--obs", "--obs-run")
    parser.set_defaults(sources=None)


# -- the diagnosis search: --max-card, --with-good --------------------------------------------


def card(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError("must be 0 or more")
    return value


def add_max_card_option(
    parser: argparse.ArgumentParser,
    default: int | None = None,
    help: str = "search diagnoses of at most K faulty components",
    type: Any = card,
) -> None:
    """``--max-card K``: the bound on the size of a diagnosis (None: no bound).  ``type`` is
    the command's own validator where its messages predate this one (replay, diagram)."""
    shown = "no bound" if default is None else str(default)
    parser.add_argument(
        "--max-card", metavar="K", type=type, default=default, help=f"{help} (default: {shown})"
    )


def add_with_good_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--with-good",
        action="store_true",
        help="with --json, also list each diagnosis's good components (all the others)",
    )


def require_json_for_good(args: argparse.Namespace, command: str) -> None:
    """``--with-good`` shapes the JSON only: alone it would be silently ignored."""
    if args.with_good and not args.json:
        print(
            f"racc {command}: error: --with-good goes with --json "
            "(the table lists each diagnosis's bad components only)",
            file=sys.stderr,
        )
        raise SystemExit(2)


def rate_hz(text: str) -> float:
    """argparse type: a rate in Hz, a finite number more than 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"a rate must be > 0, not {text}")
    return value


# -- the life of the nodes racc starts: --robot-gone (repairer, observe's agent) -------------


def robot_gone_seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of seconds: {text!r}") from None
    if not 0 < value < math.inf:
        raise argparse.ArgumentTypeError("must be more than 0 seconds")
    return value


def add_robot_gone_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--robot-gone",
        metavar="S",
        type=robot_gone_seconds,
        default=DEFAULT_GONE_S,
        help="a node racc starts is stopped when the robot stops: at once when the robot's "
        "launch ends, or once its ROS 1 master (ROS 2: every other node of the robot on this "
        "machine) has been gone this long; a master restart within it leaves the node "
        f"running (default: {DEFAULT_GONE_S:g})",
    )


# -- the planner: --planner-timeout, --validate, --json (repair, scenario) --------------------

MAX_TIMEOUT_S = 1e6  # eleven days


def planner_seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of seconds: {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError("must be more than 0")
    if not value <= MAX_TIMEOUT_S:  # inf, or beyond what the OS timers take
        raise argparse.ArgumentTypeError(f"must be at most {MAX_TIMEOUT_S:g} seconds")
    return value


def add_planner_options(
    parser: argparse.ArgumentParser, json_help: str = "print JSON (docs/spec.md#racc-repair---json)"
) -> None:
    # Here, not at the top: every command that declares an option of this module imports it,
    # and rac.repair (with its emitters) is worth loading only for the planner's commands.
    from rac.repair import DEFAULT_TIMEOUT_S

    parser.add_argument(
        "--planner-timeout",
        metavar="S",
        type=planner_seconds,
        default=DEFAULT_TIMEOUT_S,
        help="give the planner at most S seconds (default: %(default)g)",
    )
    parser.add_argument(
        "--validate",
        action="store_true",
        help="check the plan with unified-planning's plan validator (optional extra)",
    )
    parser.add_argument("--json", action="store_true", help=json_help)


# -- the board: --execute, --board, --node-commands, --board-control (repair, scenario) --------


def address_arg(text: str) -> str:
    """argparse type for HOST:PORT: a malformed address is a command-line error (exit 2)."""
    from rac.board.client import parse_address  # only with --board: asyncio is no small import

    try:
        parse_address(text)
    except RacError:
        raise argparse.ArgumentTypeError(f"'{text}' is not HOST:PORT") from None
    return text


def add_execute_options(parser: argparse.ArgumentParser) -> None:
    """``--execute --board HOST:PORT [--node-commands start=T --node-commands stop=T]``."""
    parser.add_argument(
        "--execute",
        action="store_true",
        help="carry out the plan: power_up/shutdown through --board (waiting for the MSR that "
        "shows each new state), node steps printed as commands or run from --node-commands",
    )
    add_board_options(parser)


def add_board_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--board",
        metavar="HOST:PORT",
        type=address_arg,
        help="the diagnostic board (or board-sim), needed by --execute",
    )
    parser.add_argument(
        "--node-commands",
        metavar="KIND=TEMPLATE",
        action="append",
        default=[],
        help="run node steps: start=TEMPLATE and stop=TEMPLATE, {node} is the node "
        "(without them node steps are printed, not run)",
    )
    parser.add_argument(
        "--ros",
        choices=("1", "2"),
        default=None,
        help="the ROS of the node commands printed for node steps (default: $ROS_VERSION, else 1)",
    )


def add_scenario_options(parser: argparse.ArgumentParser) -> None:
    add_board_options(parser)
    parser.add_argument(
        "--board-control",
        metavar="HOST:PORT",
        type=address_arg,
        help="board-sim's control port: trip the device there (else the scenario switches it off)",
    )


# -- replay and evaluate: --diagnose-every, --max-card -----------------------------------------

_DURATION = re.compile(r"\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*(ms|s)?\s*")
MAX_PERIOD_S = 3600.0
# A diagnosis tick every nanosecond would be 10^10 ticks for a 10 s run: replay never ended
# (and below 1e-9 s the rounded clock stopped moving at all).
MIN_PERIOD_S = 0.001


def period(text: str) -> float:
    """argparse type: ``1s``, ``500ms`` or a plain number of seconds, 1 ms to an hour."""
    match = _DURATION.fullmatch(text)
    if match is None:
        raise argparse.ArgumentTypeError(f"'{text}' is not a duration such as 1s, 500ms or 2.5")
    value = float(match[1]) / (1000.0 if match[2] == "ms" else 1.0)
    if not MIN_PERIOD_S <= value <= MAX_PERIOD_S:
        raise argparse.ArgumentTypeError(
            f"'{text}' must be from {MIN_PERIOD_S * 1000:g} ms to {MAX_PERIOD_S:g} s"
        )
    return value


def replay_card(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if not 1 <= value <= 10:
        raise argparse.ArgumentTypeError("must be from 1 to 10")
    return value


def add_replay_options(parser: argparse.ArgumentParser) -> None:
    """Options replay and evaluate share."""
    parser.add_argument(
        "--diagnose-every",
        metavar="PERIOD",
        type=period,
        default=1.0,
        help="diagnose Θ this often, and when it changes (0.2 s apart at least, as live), "
        "e.g. 1s or 500ms (default: 1s)",
    )
    add_max_card_option(parser, 3, type=replay_card)


# -- the robot's racc secret: --secret (observe, engine, repairer, board-client, confirm) ------


def add_secret_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--secret",
        metavar="FILE",
        default="",
        help="the robot's racc secret, the key racc's nodes seal their messages with: a file "
        "only this user can read, the same on every computer of the robot (default: "
        "$RACC_SECRET_FILE, else $ROS_HOME/racc/secret, else ~/.ros/racc/secret, made by the "
        "first racc node that finds none; docs/security.md)",
    )
