"""``racc confirm``: confirm the repair plan an advising repairer waits on (ROS 1 or 2)."""

from __future__ import annotations

import argparse
import getpass
import os
import socket
from typing import Any

from rac.commands.common import add_command, add_ros_option, ros_version
from rac.commands.options import add_secret_option
from rac.load.secret import load_secret


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "confirm",
        "confirm the repair plan the repairer waits on in advisory mode (ROS 1 or 2)",
        "Without PLAN, print the plan awaiting confirmation (from the latched /repair_plan). "
        "With PLAN, confirm it: the plan's id and the repairer run it belongs to are sealed "
        "with the robot's secret and your name and published on the repairer's ~confirm "
        "topic; the repairer executes the plan and says so on /repair_log, which is printed. "
        "A confirmation that is not sealed with the robot's secret is refused, so only users "
        "who can read the secret file confirm plans (docs/security.md). Exit 0 once the "
        "repairer confirms; 1 when no such plan awaits (RAC151) or no repairer answers "
        "(RAC152). ROS 1 needs a running master; works without rostopic or the ros2 CLI.",
        "  racc confirm                 # what awaits confirmation\n"
        "  racc confirm 3\n"
        "  racc confirm 3 --ros 2 --operator alice",
    )
    parser.add_argument(
        "plan", metavar="PLAN", nargs="?", help="the plan's id (as /repair_log says)"
    )
    parser.add_argument(
        "--operator",
        metavar="NAME",
        default=None,
        help="who confirms, as the repair log will say (default: USER@HOST)",
    )
    parser.add_argument(
        "--repairer",
        metavar="NODE",
        default="racc_repairer",
        help="the repairer's node name (default: racc_repairer)",
    )
    parser.add_argument(
        "--wait",
        metavar="S",
        type=float,
        default=5.0,
        help="how long to wait for the plan and for the repairer's answer (default: 5)",
    )
    add_secret_option(parser)
    add_ros_option(parser)
    parser.set_defaults(run=run)


def operator_name(given: str | None) -> str:
    """The operator as the seal names them: no blanks (ROS-name-like), USER@HOST by default."""
    name = given or f"{getpass.getuser()}@{socket.gethostname()}"
    return "_".join(name.split()) or "operator"


def run(args: argparse.Namespace) -> int:
    from rac.runtime.confirm import confirm
    from rac.runtime.trust import OPERATOR

    key = load_secret(args.secret or None, create=False)  # an operator makes no new key
    name = f"racc_confirm_{os.getpid()}"
    operator = operator_name(args.operator)
    if ros_version(args) == 2:
        from rac.ros2.common import Session

        session = Session(name, ros_args=[], key=key, role=OPERATOR, seal_as=operator)
        try:
            return confirm(session, args.plan, repairer=args.repairer, wait_s=args.wait)
        finally:
            session.close()
    from rac.ros1.common import Ros1Bus, check_master

    check_master()
    bus = Ros1Bus(name, key, OPERATOR, seal_as=operator)
    return confirm(bus, args.plan, repairer=args.repairer, wait_s=args.wait)
