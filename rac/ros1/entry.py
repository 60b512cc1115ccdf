"""Where the executables of the ``racc`` ROS package start (see :mod:`rac.ros1.package`)."""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence

from rac.ros1.common import strip_ros_args


def main(command: str, argv: Sequence[str]) -> int:
    args = strip_ros_args(argv)
    if command == "demo-node":
        return demo_node(args)
    from rac.cli import main as racc

    return racc([command, *args])


def demo_node(argv: Sequence[str]) -> int:
    """``demo_node MODEL NODE --epoch T [--seed N] [--period S] [--fault F ...]``."""
    from rac.errors import RacError
    from rac.loader import load_model
    from rac.ros1.demo_node import run_demo_node
    from rac.runtime.demo import DemoNode, parse_demo_fault

    parser = argparse.ArgumentParser(prog="demo_node")
    parser.add_argument("model")
    parser.add_argument("node")
    parser.add_argument("--epoch", type=float, required=True)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--period", type=float, default=300.0)
    parser.add_argument("--fault", action="append", default=[])
    args = parser.parse_args(argv)
    try:
        model = load_model(args.model)
        faults = [parse_demo_fault(f, model) for f in args.fault]
        demo = DemoNode(
            model,
            args.node,
            epoch=args.epoch,
            started=time.time(),
            seed=args.seed,
            period_s=args.period,
            faults=faults,
        )
    except RacError as err:
        print(err.render())
        return 1
    run_demo_node(demo)
    return 0
