"""``racc board-sim``: a simulated diagnostic board on loopback (chapter 8, Algorithm 12)."""

from __future__ import annotations

import argparse
import asyncio
import sys
from typing import Any

from rac.board.channels import DEFAULT_CHANNELS, ChannelMap, channel_map, check_fits
from rac.board.protocol import MAX_CHANNELS
from rac.board.sim import BoardSimulator
from rac.commands.common import add_command, load_checked
from rac.errors import Diagnostic, RacError

LOOPBACK = ("127.0.0.1", "::1", "localhost")


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "board-sim",
        "simulate the diagnostic hardware board",
        "Serve the board protocol (docs/board.md) on HOST:PORT until interrupted. With a "
        "model, the channels carry its switchable hardware at their channel numbers and start "
        "powered; the other channels are spare and off. It prints the port it listens on "
        "('board HOST:PORT') and the control port for fault injection ('control HOST:PORT'), "
        "which takes text lines such as 'trip jaguar', 'overcurrent 2', 'clear jaguar', "
        "'status' (or use `racc board control`).",
        "  racc board-sim --model models/tedusar.ram\n"
        "  racc board-sim --channels 4 --port 7000 --control-port 7001\n"
        "  racc board control --control 127.0.0.1:7001 trip jaguar",
    )
    parser.add_argument("--model", metavar="MODEL", help="the robot (.ram or ram/1 .json)")
    parser.add_argument(
        "--channels",
        metavar="N",
        type=int,
        help=f"number of channels (default: {DEFAULT_CHANNELS}, or the model's highest)",
    )
    parser.add_argument(
        "--host", default="127.0.0.1", help="address to bind (default: %(default)s)"
    )
    parser.add_argument(
        "--port", metavar="PORT", type=int, default=0, help="board port (default: any free one)"
    )
    parser.add_argument(
        "--control-port",
        metavar="PORT",
        type=int,
        default=0,
        help="control port (default: any free one)",
    )
    parser.add_argument(
        "--seed", type=int, default=0, help="seed of the measurement jitter (default: 0)"
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="do not log client events")
    parser.set_defaults(run=run)


def channel_count(requested: int | None, channels: ChannelMap) -> int:
    count = requested if requested is not None else max(DEFAULT_CHANNELS, channels.highest)
    if not 1 <= count <= MAX_CHANNELS:
        raise RacError([Diagnostic("RAC029", f"--channels must be 1..{MAX_CHANNELS}, not {count}")])
    check_fits(channels, count)
    return count


def log_line(text: str) -> None:
    print(f"board-sim: {text}", file=sys.stderr, flush=True)


async def serve(args: argparse.Namespace, channels: ChannelMap, count: int) -> None:
    sim = BoardSimulator(
        channels, count, seed=args.seed, log=(lambda _: None) if args.quiet else log_line
    )
    try:
        port, control = await sim.start(args.host, args.port, args.control_port)
    except OSError as err:
        raise RacError([Diagnostic("RAC090", f"cannot listen on {args.host}: {err}")]) from None
    host = f"[{args.host}]" if ":" in args.host else args.host
    print(f"board {host}:{port}", flush=True)
    print(f"control {host}:{control}", flush=True)
    for number, device in channels.devices:
        log_line(f"channel {number}: {device}")
    try:
        await asyncio.Event().wait()  # serve until interrupted
    finally:
        await sim.close()


def _command_line_problem(args: argparse.Namespace) -> str | None:
    for flag, port in (("--port", args.port), ("--control-port", args.control_port)):
        if not 0 <= port <= 65535:
            return f"{flag} must be in 0..65535 (0: any free port), not {port}"
    if args.channels is not None and not 1 <= args.channels <= MAX_CHANNELS:
        return f"--channels must be in 1..{MAX_CHANNELS}, not {args.channels}"
    return None


def run(args: argparse.Namespace) -> int:
    problem = _command_line_problem(args)
    if problem:
        print(f"racc board-sim: error: {problem}", file=sys.stderr)
        return 2
    channels = channel_map(load_checked(args.model)) if args.model else ChannelMap()
    count = channel_count(args.channels, channels)
    if args.host not in LOOPBACK:
        log_line(f"warning: listening on {args.host}; the protocol has no authentication")
    asyncio.run(serve(args, channels, count))
    return 0
