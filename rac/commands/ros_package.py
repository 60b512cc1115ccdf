"""``racc ros-package``: write the ``racc`` ROS 1 package roslaunch finds the nodes in."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Any

from rac.commands.common import add_command
from rac.errors import Diagnostic, RacError


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "ros-package",
        "write the racc ROS 1 package (package.xml and the node executables)",
        "Write DIR/racc: a package.xml and the executables observe, engine, repairer, "
        "board_client and demo_node, each run by this Python (a venv that sees Debian's ROS "
        "packages). Put DIR on ROS_PACKAGE_PATH so that the compiled observers.launch finds "
        "them.",
        "  racc ros-package -o ~/ros\n  export ROS_PACKAGE_PATH=~/ros:$ROS_PACKAGE_PATH",
    )
    parser.add_argument("-o", "--output", metavar="DIR", required=True, help="where to write")
    parser.add_argument("--python", metavar="EXE", help="interpreter (default: this one)")
    parser.add_argument("-q", "--quiet", action="store_true", help="print nothing")
    parser.set_defaults(run=run)


def write_package(out: Path, python: str | None = None) -> Path:
    from rac.ros1.package import package_files

    try:
        for rel, text in package_files(python).items():
            path = out / rel
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
            if "/scripts/" in rel:
                path.chmod(0o755)
    except OSError as err:
        raise RacError([Diagnostic("RAC004", f"{out}: cannot write: {err}")]) from None
    return out / "racc"


def run(args: argparse.Namespace) -> int:
    out = Path(args.output).resolve()
    where = write_package(out, args.python)
    if not args.quiet:
        print(f"wrote {where} (executables run {args.python or sys.executable})")
        path = os.environ.get("ROS_PACKAGE_PATH", "")
        if str(out) not in path.split(os.pathsep):
            print(f"now: export ROS_PACKAGE_PATH={out}{os.pathsep}$ROS_PACKAGE_PATH")
    return 0
