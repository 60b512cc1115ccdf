"""``racc watch``: what the live runtime sees, diagnoses and repairs, as it changes."""

from __future__ import annotations

import argparse
import os
from typing import Any

from rac.commands.common import add_command, add_ros_option, ros_version
from rac.runtime.status import DIAGNOSIS, OBSERVATIONS, REPAIR_LOG

TOPICS = {"observations": OBSERVATIONS, "diagnosis": DIAGNOSIS, "repair": REPAIR_LOG}


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "watch",
        "print /diagnosis, /repair_log and the observations as they change (ROS 1 or 2)",
        "Subscribe to the runtime's topics and print one line per change, with the time it "
        "arrived: the observations (first their count and those that do not hold, then each "
        "literal that flips), the set of diagnoses on /diagnosis, and every /repair_log entry "
        "(level, action, target, outcome). Works without rostopic or the ros2 CLI. Ctrl-C "
        "stops it. ROS 1 needs a running master; ROS 2 rclpy.",
        "  racc watch\n"
        "  racc watch --ros 2 --only diagnosis --only repair\n"
        "  racc watch --duration 60 > loop.txt",
    )
    parser.add_argument(
        "--only",
        action="append",
        choices=sorted(TOPICS),
        help="watch only these (repeatable; default: observations, diagnosis and repair)",
    )
    parser.add_argument(
        "--duration",
        metavar="S",
        type=float,
        help="stop after S seconds (default: until Ctrl-C)",
    )
    add_ros_option(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from rac.runtime.watch import run_watch

    topics = [TOPICS[t] for t in (args.only or ("observations", "diagnosis", "repair"))]
    name = f"racc_watch_{os.getpid()}"

    def out(line: str) -> None:
        print(line, flush=True)

    if ros_version(args) == 2:
        from rac.ros2.common import Session

        session = Session(name, ros_args=[])
        try:
            run_watch(session, topics, args.duration, out)
        except KeyboardInterrupt:
            pass  # rclpy's SIGINT handler raises it after stopping the session: a clean end
        finally:
            session.close()
    else:
        from rac.ros1.common import Ros1Bus, check_master

        check_master()
        run_watch(Ros1Bus(name), topics, args.duration, out)
    return 0
