"""``racc board-client``: the board client node (Algorithm 13) for a live robot."""

from __future__ import annotations

import argparse
from typing import Any

from rac.board.channels import ChannelMap
from rac.board.client import parse_address
from rac.commands.common import add_command, add_ros_option, ros_version
from rac.commands.options import add_secret_option
from rac.load.files import load_observers
from rac.load.secret import load_secret
from rac.observe.hobs import parse_channels


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "board-client",
        "connect the diagnostic board to ROS 1 or 2 (/board_measurements, /board_switch)",
        "Connect to the board at --board, publish its measurements on /board_measurements "
        "(one status per channel, docs/runtime.md) and switch channels on requests from the "
        "repair node on /board_switch (diagnostic_msgs/KeyValue: device, on|off). Channels are "
        "named after the devices of the HObs in OBSERVERS. Needs ROS 1 (rospy) or ROS 2 "
        "(rclpy).",
        "  racc board-client build/tedusar/observers.yaml --board 127.0.0.1:7000",
    )
    parser.add_argument("observers", metavar="OBSERVERS", help="observers.yaml")
    parser.add_argument(
        "--board",
        metavar="HOST:PORT",
        required=True,
        type=_address,
        help="the diagnostic board (or board-sim)",
    )
    parser.add_argument(
        "--hz",
        type=int,
        default=10,
        help="measurements per second the board is asked for (default: 10)",
    )
    add_secret_option(parser)
    add_ros_option(parser)
    parser.set_defaults(run=run)


def _address(text: str) -> Any:
    from rac.errors import RacError

    try:
        return parse_address(text)
    except RacError as err:
        raise argparse.ArgumentTypeError(err.diagnostics[0].message) from None


def channels_of(path: str) -> ChannelMap:
    _, specs = load_observers(path)
    pairs = [
        (number, device)
        for s in specs
        if s.kind == "HObs"
        for device, number in parse_channels(s, str(dict(s.params).get("channels", "")))
    ]
    return ChannelMap(tuple(sorted(pairs)))


def run(args: argparse.Namespace) -> int:
    if ros_version(args) == 2:
        from rac.ros2.board_client import run_board_client
    else:
        from rac.ros1.board_client import run_board_client
    run_board_client(
        args.board,
        channels_of(args.observers),
        hz=args.hz,
        key=load_secret(args.secret or None),
    )
    return 0
