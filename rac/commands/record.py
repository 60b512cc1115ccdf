"""``racc record``: record a running ROS 1 system for ``racc learn`` (§9.1.1)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from rac.commands.common import add_command, add_ros_option, ros_version
from rac.errors import Diagnostic, RacError


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "record",
        "record a running ROS 1 or 2 system (bag, properties CSV, computation graph)",
        "Record every topic into a bag for --duration seconds (ROS 1: a .bag file; ROS 2: a "
        "rosbag2 directory, sqlite3), the cpu and memory of every node (psutil, 2 Hz) into a "
        "properties CSV, and the computation graph into a YAML file, in the shapes 'racc "
        "learn' reads. Needs ROS 1 and a running master, or ROS 2 (rclpy).",
        "  racc record -o run1.bag --duration 60\n"
        "  racc learn run1.bag --graph run1.graph.yaml --properties run1.properties.csv "
        "-o robot.ram\n"
        "  racc record --ros 2 -o run2 --duration 60",
    )
    parser.add_argument(
        "-o",
        "--output",
        metavar="RUN",
        required=True,
        help="the recording: a .bag file (ROS 2: a bag directory)",
    )
    parser.add_argument(
        "--duration", type=float, required=True, metavar="S", help="how long to record, in seconds"
    )
    parser.add_argument(
        "--properties",
        metavar="CSV",
        help="where the cpu and memory samples go (default: RUN.properties.csv)",
    )
    parser.add_argument(
        "--graph", metavar="YAML", help="where the computation graph goes (default: RUN.graph.yaml)"
    )
    parser.add_argument(
        "--include",
        metavar="PATTERN",
        nargs="+",
        default=[],
        help="also record nodes and topics matching these globs, which are left out by "
        "default: racc's own topics (/diagnosis, /observations, /repair_log, "
        "/board_measurements, /board_switch) and nodes (/racc_*), ROS's tool nodes "
        "(/rostopic_*, /rosnode_*, /rosservice_*, /record_*, /rqt*) and /rosout "
        "(default: none)",
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="print nothing")
    add_ros_option(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    bag = Path(args.output)
    stem = bag.with_suffix("") if bag.suffix == ".bag" else bag
    csv = Path(args.properties or f"{stem}.properties.csv")
    graph = Path(args.graph or f"{stem}.graph.yaml")
    if bag.exists():
        raise RacError([Diagnostic("RAC084", f"{bag}: already exists; choose another name")])
    if ros_version(args) == 2:
        from rac.ros2.record import run_record
    else:
        from rac.ros1.common import check_master
        from rac.ros1.record import run_record

        check_master()
    from rac.learn.graph import Exclusions

    exclusions = Exclusions(tuple(args.include))
    messages, topics = run_record(bag, csv, graph, args.duration, exclusions=exclusions)
    if not args.quiet:
        print(f"recorded {messages} messages on {topics} topics into {bag}")
        print(f"  wrote {csv}\n  wrote {graph}")
    return 0
