"""``racc repairer``: the repair node (Algorithm 11, every step verified)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from rac.commands.common import add_command, add_ros_option, ros_version
from rac.commands.options import add_robot_gone_option, add_secret_option
from rac.errors import Diagnostic, RacError, did_you_mean
from rac.load.files import load_observers
from rac.load.kinds import OBSERVERS, ROBOT_LAUNCH, check_kind
from rac.load.secret import load_secret
from rac.load.theory import load_theory, robot_name
from rac.logic import mangle
from rac.observe.hobs import parse_channels
from rac.passes.machines import machines_of, node_placements
from rac.runtime.nodes import RepairJob
from rac.runtime.repairer import Mode, Settings


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "repairer",
        "run the repair engine as a ROS node (ROS 1 or 2)",
        "Plan a repair with Fast Downward for each diagnosis on /diagnosis (Algorithm 11, "
        "with the observations of /observations) and execute it: a node is stopped and started "
        "again from its entry in the launch file given with --launch (ROS 1: the command "
        "roslaunch would run; ROS 2: the <node> of a launch XML file, started as ros2 launch "
        "would, or the command of --restart-command), once its old process is proven gone "
        "(never two copies), detached from racc so that it outlives it, under a guardian "
        "that stops it when the robot stops (--robot-gone); a switchable device is switched "
        "through the board client. A diagnosis must stand "
        "--confirm seconds, a node never seen running is left alone for --startup-grace "
        "seconds, each component has a budget of repairs (--budget in --budget-window) with a "
        "doubling back-off (--backoff), a plan is aborted when its diagnosis clears, and "
        "nothing is repaired while the robot shuts down. Each step waits until its effect "
        "shows in the observations (--step-timeout), is tried once more (a node that does not "
        "stop is killed), then the repair is abandoned with an escalation (RAC110). Every "
        "decision goes to /repair_log, the repairer's state to /diagnostics. --advise "
        "publishes each plan on /repair_plan and executes it once an operator publishes its "
        "id on the repairer's ~confirm topic; --dry-run only logs. Needs ROS 1 (rospy, "
        "roslaunch) or ROS 2 (rclpy).",
        "  racc repairer build/tedusar/model.yaml --launch robot.launch\n"
        "  racc repairer build/tedusar/model.yaml --launch robot.launch --step-timeout 8\n"
        "  racc repairer build/tedusar/model.yaml --launch robot.launch --advise\n"
        "  rostopic pub -1 /racc_repairer/confirm std_msgs/String 3   # execute plan 3\n"
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
    s = Settings()
    # (option, metavar, type, default, help): the repair policy's numbers (docs/runtime.md)
    policy: tuple[tuple[str, str, type, float, str], ...] = (
        (
            "--step-timeout",
            "S",
            float,
            5.0,
            "seconds a step may take to show its effect, from its request, then it is tried "
            "once more (a node that did not stop is killed) (default: 5)",
        ),
        (
            "--verify-timeout",
            "S",
            float,
            10.0,
            "seconds the engine has to report no fault after a plan (default: 10)",
        ),
        (
            "--confirm",
            "S",
            float,
            s.confirm_s,
            f"seconds a diagnosis must stand before a plan (default: {s.confirm_s:g})",
        ),
        (
            "--startup-grace",
            "S",
            float,
            s.startup_grace_s,
            "seconds a node never seen running is left alone, from the repairer's start, "
            "the node's first observation and the robot's return "
            f"(default: {s.startup_grace_s:g})",
        ),
        (
            "--budget",
            "N",
            int,
            s.budget,
            "repairs of one component within --budget-window; one more is escalated "
            f"(RAC110) and the component left alone until the window frees (default: {s.budget})",
        ),
        (
            "--budget-window",
            "S",
            float,
            s.budget_window_s,
            f"seconds of the repair budget's window (default: {s.budget_window_s:g})",
        ),
        (
            "--backoff",
            "S",
            float,
            s.backoff_s,
            "seconds between a component's first and second repair in the window, doubled "
            f"for each further one (default: {s.backoff_s:g})",
        ),
    )
    for option, metavar, kind, default, text in policy:
        parser.add_argument(option, metavar=metavar, type=kind, default=default, help=text)
    modes = parser.add_mutually_exclusive_group()
    modes.add_argument(
        "--mode",
        choices=[m.value for m in Mode],
        default=Mode.ACT.value,
        help="act: execute plans; advise: publish each plan on /repair_plan and execute it "
        "once its id is published on ~confirm; dry-run: log plans, never act (default: act)",
    )
    modes.add_argument(
        "--advise", dest="mode", action="store_const", const="advise", help="--mode advise"
    )
    modes.add_argument(
        "--dry-run", dest="mode", action="store_const", const="dry-run", help="--mode dry-run"
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
    add_secret_option(parser)
    add_robot_gone_option(parser)
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


def settings_from(args: argparse.Namespace) -> Settings:
    """The executor's settings from the options; RAC125 for one out of range."""
    seconds = {
        "--confirm": args.confirm,
        "--startup-grace": args.startup_grace,
        "--budget-window": args.budget_window,
        "--backoff": args.backoff,
        "--step-timeout": args.step_timeout,
        "--verify-timeout": args.verify_timeout,
    }
    bad = [f"{name} {value:g}" for name, value in seconds.items() if not value >= 0]
    if args.budget < 1:
        bad.append(f"--budget {args.budget}")
    if bad:
        raise RacError(
            [
                Diagnostic(
                    "RAC125",
                    f"repairer option out of range: {', '.join(bad)}",
                    hint="give times as seconds >= 0 and a budget of at least 1",
                )
            ]
        )
    return Settings(
        confirm_s=args.confirm,
        startup_grace_s=args.startup_grace,
        step_timeout_s=args.step_timeout,
        verify_timeout_s=args.verify_timeout,
        budget=args.budget,
        budget_window_s=args.budget_window,
        backoff_s=args.backoff,
        strategy=args.strategy,
        mode=Mode(args.mode),
    )


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
    settings = settings_from(args)
    theory = load_theory(args.model)
    ros = ros_version(args)
    if args.launch:
        check_kind(args.launch, ROBOT_LAUNCH, "RAC117" if ros == 2 else "RAC059")
    if args.observers:
        check_kind(args.observers, OBSERVERS, "RAC056")
    observers = args.observers or str(Path(args.model).parent / "observers.yaml")
    placements, machines = where(observers)
    if args.machine and Path(observers).is_file() and args.machine not in machines:  # no ROS yet
        known = ", ".join(machines) or "none"
        message = f"{observers}: the model has no machine '{args.machine}' (machines: {known})"
        hint = did_you_mean(args.machine, machines) or (
            "give a machine the model declares ('machine NAME'), or leave --machine out"
        )
        raise RacError([Diagnostic("RAC140", message, hint=hint)])
    if args.launch and ros == 2:
        from rac.ros2.launch import load_launch

        load_launch(args.launch)  # RAC117 before any ROS work
    elif args.launch:
        from rac.ros1.actuator import load_launch_nodes
        from rac.ros1.common import require_ros

        require_ros()  # RAC057 without ROS 1 (roslaunch reads the file)
        load_launch_nodes(args.launch)  # RAC059 before any ROS work
    args.launch = args.launch or None  # the compiled launch file passes "--launch=" for none
    nodes, devices = names(observers)
    job = RepairJob(
        theory,
        robot_name(theory, args.model),
        args.launch,
        nodes,
        devices,
        settings,
        placements=placements,
        machine=args.machine or (machines[0] if machines else None),
        key=load_secret(args.secret or None),
    )
    if ros == 2:
        from rac.ros2.repairer import run_repairer as run2

        run2(job, restart=args.restart_command or None, robot_gone_s=args.robot_gone)
        return 0
    from rac.ros1.repairer import run_repairer

    run_repairer(job, robot_gone_s=args.robot_gone)
    return 0
