"""``racc repairer``: the repair node (Algorithm 11, every step verified)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from rac.commands.common import add_command, add_ros_option, ros_version
from rac.diagnosis import load_theory
from rac.loader import load_observers
from rac.logic import mangle
from rac.observe.hobs import parse_channels
from rac.passes.machines import machines_of, node_placements
from rac.repair import robot_name
from rac.runtime.nodes import RepairJob
from rac.runtime.repairer import Settings


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "repairer",
        "run the repair engine as a ROS node (ROS 1 or 2)",
        "Plan a repair with Fast Downward for each diagnosis on /diagnosis (Algorithm 11, "
        "with the observations of /observations) and execute it: a node is stopped and started "
        "again from its entry in the launch file given with --launch (ROS 1: roslaunch's Python "
        "API; ROS 2: the <node> of a launch XML file, started as ros2 launch would, or the "
        "command of --restart-command), "
        "a switchable device is switched through the board client. Each step waits until its "
        "effect shows in the observations (--step-timeout), is tried once more, then the "
        "repair is abandoned with an escalation (RAC110). Every action and outcome goes to "
        "/repair_log. Needs ROS 1 (rospy, roslaunch) or ROS 2 (rclpy).",
        "  racc repairer build/tedusar/model.yaml --launch robot.launch\n"
        "  racc repairer build/tedusar/model.yaml --launch robot.launch --step-timeout 8\n"
        "  racc repairer build/tedusar/model.yaml --ros 2 --launch robot.launch.xml\n"
        "  racc repairer build/tedusar/model.yaml --ros 2 "
        "--restart-command 'ros2 run my_robot {node} --ros-args -r __node:={node}'",
    )
    parser.add_argument("model", metavar="MODEL", help="model.yaml (or .ram/.json)")
    parser.add_argument(
        "--launch", metavar="FILE", help="the robot's own launch file, whose nodes are restarted"
    )
    parser.add_argument(
        "--restart-command",
        metavar="TEMPLATE",
        help="ROS 2: the command that starts a node the launch file lacks ({node}: its name)",
    )
    parser.add_argument(
        "--observers", metavar="FILE", help="observers.yaml (default: beside MODEL)"
    )
    parser.add_argument(
        "--step-timeout",
        metavar="S",
        type=float,
        default=5.0,
        help="seconds a step may take to show its effect, then it is tried once more (default: 5)",
    )
    parser.add_argument(
        "--verify-timeout",
        metavar="S",
        type=float,
        default=10.0,
        help="seconds the engine has to report no fault after a plan (default: 10)",
    )
    parser.add_argument(
        "--strategy",
        choices=("minimal", "first"),
        default="minimal",
        help="which diagnosis to repair, as in racc repair (default: minimal)",
    )
    parser.add_argument(
        "--machine",
        metavar="NAME",
        help="the machine this repairer runs on: nodes of other machines are restarted by "
        "their machine's racc agent (default: the machine of the robot-wide observers in "
        "observers.yaml, else the first named there; the compiled launch file gives the "
        "model's first machine)",
    )
    add_ros_option(parser)
    parser.set_defaults(run=run)


def names(observers: str | None) -> tuple[dict[str, str], dict[str, str]]:
    """component -> ROS node name, component -> device name, from observers.yaml."""
    if observers is None or not Path(observers).is_file():
        return {}, {}
    _, specs = load_observers(observers)
    nodes: dict[str, str] = {}
    devices: dict[str, str] = {}
    for s in specs:
        params = dict(s.params)
        if s.kind == "NObs":
            node = str(params.get("node", "")).lstrip("/")
            nodes[mangle(node)] = node
        if s.kind == "HObs":
            for device, _ in parse_channels(s, str(params.get("channels", ""))):
                devices[mangle(device)] = device
    return nodes, devices


def where(
    observers: str | None,
) -> tuple[dict[str, tuple[str | None, str | None]], tuple[str, ...]]:
    """Each node's machine and container, and the machines, from observers.yaml."""
    if observers is None or not Path(observers).is_file():
        return {}, ()
    _, specs = load_observers(observers)
    placements = {n: p for n, p in node_placements(specs).items() if p != (None, None)}
    return placements, machines_of(specs)


def run(args: argparse.Namespace) -> int:
    theory = load_theory(args.model)
    ros = ros_version(args)
    if args.launch and ros == 2:
        from rac.ros2.launch import load_launch

        load_launch(args.launch)  # RAC117 before any ROS work
    elif args.launch:
        from rac.ros1.repairer import load_launch_nodes

        load_launch_nodes(args.launch)  # RAC059 before any ROS work
    observers = args.observers or str(Path(args.model).parent / "observers.yaml")
    args.launch = args.launch or None  # the compiled launch file passes "--launch=" for none
    nodes, devices = names(observers)
    settings = Settings(
        step_timeout_s=args.step_timeout,
        verify_timeout_s=args.verify_timeout,
        strategy=args.strategy,
    )
    placements, machines = where(observers)
    job = RepairJob(
        theory,
        robot_name(theory, args.model),
        args.launch,
        nodes,
        devices,
        settings,
        placements=placements,
        machine=args.machine or (machines[0] if machines else None),
    )
    if ros == 2:
        from rac.ros2.repairer import run_repairer as run2

        run2(job, restart=args.restart_command or None)
        return 0
    from rac.ros1.repairer import run_repairer

    run_repairer(job)
    return 0
