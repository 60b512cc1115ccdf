"""``racc engine``: the diagnosis node (model server and engine, §6.3 and §6.4)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from rac.commands.common import add_command, add_ros_option, ros_version
from rac.commands.options import add_max_card_option, add_secret_option
from rac.load.secret import load_secret
from rac.load.theory import load_theory, robot_name


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "engine",
        "run the diagnosis engine as a ROS node (ROS 1 or 2)",
        "Collect /observations as Algorithm 10 does and publish the minimal diagnoses of MODEL "
        "(model.yaml, .ram or .json) on /diagnosis (one status per diagnosis, none when "
        "healthy) and a summary on /diagnostics, RATE times a second. The model is reloaded "
        "when its file changes, or on a message to ~reload (std_msgs/String: a path inside "
        "--reload-dir, or empty for the same file), without a restart. Observations count "
        "only from racc's observer hosts (--hosts), sealed with the robot's secret. Needs "
        "ROS 1 (rospy) or ROS 2 (rclpy; there the reload topic is ~/reload, "
        "std_msgs/msg/String).",
        "  racc engine build/tedusar/model.yaml\n"
        "  racc engine build/tedusar/model.yaml --rate 2 --max-card 2\n"
        "  rostopic pub -1 /racc_engine/reload std_msgs/String ''\n"
        "  ros2 topic pub -1 /racc_engine/reload std_msgs/msg/String \"{data: ''}\"",
    )
    parser.add_argument("model", metavar="MODEL", help="model.yaml (or .ram/.json)")
    parser.add_argument("--rate", type=float, default=1.0, help="diagnoses per second (default: 1)")
    add_max_card_option(parser, type=int)
    parser.add_argument(
        "--hosts",
        metavar="NAME,...",
        default="",
        help="the observer hosts whose /observations count, comma-separated node names "
        "(default: any racc observer host with the robot's secret; the compiled launch "
        "files name the ones they start)",
    )
    parser.add_argument(
        "--reload-dir",
        metavar="DIR",
        default=None,
        help="the only directory ~reload may load a model from ('none': only the model "
        "file itself; default: MODEL's directory)",
    )
    add_secret_option(parser)
    add_ros_option(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    theory = load_theory(args.model)  # errors before any ROS work
    if ros_version(args) == 2:
        from rac.ros2.engine import run_engine
    else:
        from rac.ros1.engine import run_engine
    reload_dir = args.reload_dir
    if reload_dir is None:
        reload_dir = str(Path(args.model).resolve().parent)
    elif reload_dir.strip().lower() == "none":
        reload_dir = None
    run_engine(
        args.model,
        load_theory,
        robot_name(theory, args.model),
        rate_hz=args.rate,
        max_card=args.max_card,
        key=load_secret(args.secret or None),
        hosts=tuple(h.strip() for h in args.hosts.split(",") if h.strip()),
        reload_dir=reload_dir,
    )
    return 0
