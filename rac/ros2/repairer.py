"""The repair node on ROS 2 (``racc repairer --ros 2``): Algorithm 11 on a live ROS 2
system.  The executor (:mod:`rac.runtime.repairer`) decides; this node carries out its
requests:

- start_node(n): the ``<node>`` named ``n`` in the robot's ROS 2 launch file
  (``--launch``), started as ``ros2 launch`` would start it (:mod:`rac.ros2.launch`), or
  else the command ``--restart-command`` gives (``{node}`` replaced by the node's name);
- stop_node(n): a process this repairer started, or else every outermost local process
  whose command line says ``__node:=n``, gets SIGINT, then SIGTERM, then SIGKILL;
- shutdown(d) / power_up(d): a request on ``/board_switch`` to the board client node.
"""

from __future__ import annotations

import os
import shlex
import subprocess
import threading

from rac.errors import Diagnostic, RacError
from rac.ros2.agent import routed_actuator
from rac.ros2.common import Session, reliable
from rac.ros2.launch import LaunchNode, command_line, load_launch
from rac.runtime.nodes import RepairJob, run_repair_node
from rac.runtime.procs import STOP_SIGNALS, node_processes, outermost, terminate


class Ros2Actuator:
    def __init__(self, session: Session, launch_file: str | None, restart: str | None) -> None:
        from diagnostic_msgs.msg import KeyValue

        self.session = session
        self.launch_file, self.restart = launch_file, restart
        nodes = load_launch(launch_file) if launch_file else []
        self.entries: dict[str, LaunchNode] = {n.key: n for n in nodes if n.name}
        self.started: dict[str, subprocess.Popen[bytes]] = {}
        self.KeyValue = KeyValue
        self.switches = session.node.create_publisher(KeyValue, "/board_switch", reliable(10))

    def _command(self, node: str) -> tuple[list[str], dict[str, str]]:
        entry = self.entries.get(node.strip("/"))
        if entry is not None:
            return command_line(entry), dict(entry.env)
        if self.restart:
            return shlex.split(self.restart.format(node=node.strip("/"))), {}
        where = self.launch_file or "no launch file (give one with --launch)"
        raise RacError(
            [
                Diagnostic(
                    "RAC111",
                    f"node '{node}' has no entry in {where}",
                    hint="or give --restart-command, e.g. 'ros2 run PKG EXEC --ros-args -r "
                    "__node:={node}'",
                )
            ]
        )

    def start_node(self, node: str) -> None:
        args, env = self._command(node)
        try:
            self.started[node] = subprocess.Popen(args, env={**os.environ, **env})
        except OSError as err:
            raise RacError([Diagnostic("RAC111", f"cannot start '{node}': {err}")]) from None

    def stop_node(self, node: str) -> None:
        proc = self.started.pop(node, None)
        pids = [proc.pid] if proc is not None and proc.poll() is None else []
        if not pids:
            pids = [p.pid for p in outermost(node_processes(node))]
        for pid in pids:
            threading.Thread(target=terminate, args=(pid, STOP_SIGNALS), daemon=True).start()

    def switch(self, device: str, on: bool) -> None:
        if self.switches.get_subscription_count() == 0:
            raise RacError(
                [
                    Diagnostic(
                        "RAC114",
                        "no board client listens on /board_switch",
                        hint="start it with 'racc board-client --ros 2' (the compiled "
                        "launch files do)",
                    )
                ]
            )
        self.switches.publish(self.KeyValue(key=device, value="on" if on else "off"))

    def reap(self) -> None:
        for proc in self.started.values():
            proc.poll()

    def shutdown(self) -> None:
        for proc in self.started.values():
            if proc.poll() is None:
                terminate(proc.pid, STOP_SIGNALS)
                proc.poll()


def run_repairer(job: RepairJob, restart: str | None = None, name: str = "racc_repairer") -> None:
    session = Session(name)
    actuator = Ros2Actuator(session, job.launch_file, restart)
    try:
        routed = routed_actuator(session, job, actuator)
        run_repair_node(session, routed, job, after_tick=actuator.reap)
    finally:
        actuator.shutdown()
        session.close()
