"""``racc board status|switch|control``: talk to the diagnostic board (chapter 8)."""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import sys
from typing import Any

from rac.board.channels import ChannelMap, channel_map, check_fits, hobs_literals, resolve_target
from rac.board.client import BoardClient, ClientSettings, parse_address
from rac.board.control import HELP, VERBS, send_control
from rac.board.protocol import Measurements
from rac.commands.common import add_command, load_checked
from rac.commands.options import address_arg
from rac.errors import Diagnostic, RacError, did_you_mean


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "board",
        "read and switch the diagnostic hardware board",
        "Talk to a diagnostic board (or `racc board-sim`) over the protocol of docs/board.md. "
        "With --model, channels are named by the model's switchable hardware.",
        "  racc board status --board 127.0.0.1:7000 --model models/tedusar.ram\n"
        "  racc board switch --board 127.0.0.1:7000 --model models/tedusar.ram jaguar off\n"
        "  racc board switch --board 127.0.0.1:7000 4 on\n"
        "  racc board control --control 127.0.0.1:7001 trip jaguar",
    )
    actions = parser.add_subparsers(dest="board_command", metavar="ACTION")
    status = add_command(
        actions,
        "status",
        "print every channel and the hardware observer's literals",
        "Print channel, device, on/off, current and voltage from one MSR, then the HObs "
        "literals (on(h) / not_on(h), §5.2.6) of the model's devices.",
        "  racc board status --board 127.0.0.1:7000 --model models/tedusar.ram --json",
    )
    switch = add_command(
        actions,
        "switch",
        "switch one channel on or off and wait until the board shows it",
        "Send SWT for DEVICE (a switchable device of --model, or a channel number) and wait "
        "for the MSR that shows the new state; exit 1 when it does not come.",
        "  racc board switch --board 127.0.0.1:7000 --model models/tedusar.ram jaguar on",
    )
    control = add_command(
        actions,
        "control",
        "send one fault-injection line to `racc board-sim`'s control port",
        "Send LINE (trip T, overcurrent T, disconnect T, jam T, clear T, on T, off T, status) "
        "to the simulator's control port and print its reply; exit 1 on an 'error' reply.",
        "  racc board control --control 127.0.0.1:7001 overcurrent hokuyo",
    )
    for p in (status, switch):
        p.add_argument(
            "--board",
            required=True,
            metavar="HOST:PORT",
            type=address_arg,
            help="the board's address",
        )
        p.add_argument(
            "--model",
            metavar="MODEL",
            help="the robot (.ram or .json), which names the channels (default: channel numbers "
            "only)",
        )
        p.add_argument(
            "--timeout", type=float, default=2.0, help="seconds per wait (default: %(default)s)"
        )
        p.set_defaults(run=run)
    status.add_argument("--json", action="store_true", help="print JSON instead of a table")
    switch.add_argument("device", metavar="DEVICE", help="device name or channel number")
    switch.add_argument("state", choices=("on", "off"), help="the state to switch to")
    control.add_argument(
        "--control",
        required=True,
        metavar="HOST:PORT",
        type=address_arg,
        help="board-sim's control port",
    )
    control.add_argument(
        "line",
        nargs="+",
        metavar="LINE",
        help="the control line: trip, overcurrent, disconnect, jam, clear, on or off and a device"
        " or channel; status; help",
    )
    control.set_defaults(run=run)
    parser.set_defaults(run=run)


def table(channels: ChannelMap, msr: Measurements) -> str:
    lines = [f"{'channel':>7}  {'device':<20} {'state':<5} {'current A':>9} {'voltage V':>9}"]
    for number, reading in enumerate(msr.channels, start=1):
        device = channels.device(number) or "-"
        state = "on" if reading.on else "off"
        lines.append(
            f"{number:>7}  {device:<20} {state:<5} {reading.current:>9.2f} {reading.voltage:>9.2f}"
        )
    return "\n".join(lines)


def as_json(channels: ChannelMap, msr: Measurements, pretty: bool = False) -> str:
    rows = [
        {
            "channel": n,
            "device": channels.device(n),
            "on": r.on,
            "current": round(r.current, 3),
            "voltage": round(r.voltage, 3),
        }
        for n, r in enumerate(msr.channels, start=1)
    ]
    doc = {"channels": rows, "observations": list(hobs_literals(channels, msr))}
    return json.dumps(doc, indent=2 if pretty else None)


async def status(args: argparse.Namespace, channels: ChannelMap) -> int:
    settings = ClientSettings(timeout_s=args.timeout)
    async with BoardClient(parse_address(args.board), settings) as board:
        check_fits(channels, board.channel_count)
        msr = await board.measure()
    if args.json:
        print(as_json(channels, msr, args.pretty))
    else:
        print(table(channels, msr))
        literals = hobs_literals(channels, msr)
        if literals:
            print("observations: " + " ".join(literals))
    return 0


async def switch(args: argparse.Namespace, channels: ChannelMap) -> int:
    on = args.state == "on"
    settings = ClientSettings(timeout_s=args.timeout)
    resolve_target(args.device, channels)  # an unknown device before connecting (RAC092)
    async with BoardClient(parse_address(args.board), settings) as board:
        number = resolve_target(args.device, channels, board.channel_count)
        await board.switch(number, on)
        msr = await board.wait_for_state(number, on, args.timeout)
    reading = msr.channels[number - 1]
    name = channels.device(number) or "spare"
    print(
        f"channel {number} ({name}) is {args.state}: "
        f"{reading.current:.2f} A, {reading.voltage:.2f} V"
    )
    return 0


async def control(args: argparse.Namespace) -> int:
    verb = args.line[0].lower()
    if verb not in VERBS:  # say so before connecting: the simulator may not even run
        hint = did_you_mean(verb, VERBS) or HELP
        raise RacError([Diagnostic("RAC091", f"unknown control command '{verb}'", hint=hint)])
    address = parse_address(args.control)
    try:
        reply = await send_control(address.host, address.port, " ".join(args.line))
    except (OSError, TimeoutError, asyncio.TimeoutError) as err:
        raise RacError(
            [
                Diagnostic(
                    "RAC090", f"cannot reach the control port {address}: {str(err) or 'timed out'}"
                )
            ]
        ) from None
    print(reply)
    return 0 if reply.startswith("ok") else 1


def run(args: argparse.Namespace) -> int:
    command = getattr(args, "board_command", None)
    if command is None:
        print("racc board: give an action: status, switch or control", file=sys.stderr)
        return 2
    if command == "control":
        return asyncio.run(control(args))
    if not (math.isfinite(args.timeout) and args.timeout > 0):
        print(f"racc board {command}: error: --timeout must be above 0 seconds", file=sys.stderr)
        return 2
    channels = channel_map(load_checked(args.model)) if args.model else ChannelMap()
    if command == "status":
        return asyncio.run(status(args, channels))
    return asyncio.run(switch(args, channels))


# -- `racc repair --execute` and `racc scenario --board` (issue 6, item 4) --------------------
# repair.py and scenario.py call these, so that their own code stays about planning.
