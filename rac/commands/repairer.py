"""``racc repairer``: the repair node (Algorithm 11, every step verified)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from rac.commands.common import add_command
from rac.diagnosis import load_theory
from rac.loader import load_observers
from rac.logic import mangle
from rac.observe.hobs import parse_channels
from rac.repair import robot_name
from rac.runtime.repairer import Settings


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "repairer",
        "run the repair engine as a ROS 1 node",
        "Plan a repair with Fast Downward for each diagnosis on /diagnosis (Algorithm 11, "
        "with the observations of /observations) and execute it: a node is stopped and started "
        "again from its entry in the launch file given with --launch (roslaunch's Python API), "
        "a switchable device is switched through the board client. Each step waits until its "
        "effect shows in the observations (--step-timeout), is tried once more, then the "
        "repair is abandoned with an escalation (RAC110). Every action and outcome goes to "
        "/repair_log. Needs ROS 1 (rospy, roslaunch).",
        "  racc repairer build/tedusar/model.yaml --launch robot.launch\n"
        "  racc repairer build/tedusar/model.yaml --launch robot.launch --step-timeout 8",
    )
    parser.add_argument("model", metavar="MODEL", help="model.yaml (or .ram/.json)")
    parser.add_argument(
        "--launch", metavar="FILE", help="the robot's own launch file, whose nodes are restarted"
    )
    parser.add_argument(
        "--observers", metavar="FILE", help="observers.yaml (default: beside MODEL)"
    )
    parser.add_argument("--step-timeout", type=float, default=5.0, help="seconds per step (5)")
    parser.add_argument(
        "--verify-timeout", type=float, default=10.0, help="seconds for 'no fault' after a plan"
    )
    parser.add_argument(
        "--strategy", default="minimal", help="which diagnosis to repair (as racc repair)"
    )
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


def run(args: argparse.Namespace) -> int:
    from rac.ros1.repairer import load_launch_nodes, run_repairer

    theory = load_theory(args.model)
    if args.launch:
        load_launch_nodes(args.launch)  # RAC059 before any ROS work
    observers = args.observers or str(Path(args.model).parent / "observers.yaml")
    args.launch = args.launch or None  # the compiled launch file passes "--launch=" for none
    nodes, devices = names(observers)
    settings = Settings(
        step_timeout_s=args.step_timeout,
        verify_timeout_s=args.verify_timeout,
        strategy=args.strategy,
    )
    run_repairer(
        theory,
        robot_name(theory, args.model),
        launch_file=args.launch,
        nodes=nodes,
        devices=devices,
        settings=settings,
    )
    return 0
