"""The repair node on ROS 2 (``racc repairer --ros 2``): Algorithm 11 on a live ROS 2
system.  The executor (:mod:`rac.runtime.repairer`) decides; this node carries out its
requests:

- start_node(n): the ``<node>`` named ``n`` in the robot's ROS 2 launch file
  (``--launch``), started as ``ros2 launch`` would start it (:mod:`rac.ros2.launch`), or
  else the command ``--restart-command`` gives (``{node}`` replaced by the node's name);
  Started nodes are detached from racc (a session of their own): they belong to the
  robot and outlive racc;
- stop_node(n): a process this repairer started (its session), or else every outermost
  local process whose command line says ``__node:=n``, gets SIGINT, then SIGTERM;
- kill_node(n): SIGKILL to the session racc started, or else to every local process of
  the node (a node that did not stop within the step time-out);
- shutdown(d) / power_up(d): a request on ``/board_switch`` to the board client node.
"""

from __future__ import annotations

import os
import shlex
import signal
import threading

from rac.errors import Diagnostic, RacError
from rac.ros2.common import Session, graph_nodes, reliable
from rac.ros2.launch import LaunchNode, command_line, load_launch
from rac.runtime.detached import Detached, kill_pids, started_note
from rac.runtime.nodes import RepairJob, run_repair_node
from rac.runtime.procs import node_processes, outermost, terminate

POLITE = (signal.SIGINT, signal.SIGTERM)  # the executor kills after the step time-out


class Ros2Actuator:
    def __init__(self, session: Session, launch_file: str | None, restart: str | None) -> None:
        from diagnostic_msgs.msg import KeyValue

        self.session = session
        self.launch_file, self.restart = launch_file, restart
        nodes = load_launch(launch_file) if launch_file else []
        self.entries: dict[str, LaunchNode] = {n.key: n for n in nodes if n.name}
        self.detached = Detached()
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

    def start_node(self, node: str) -> str:
        args, env = self._command(node)
        pid, log = self.detached.start(node, args, {**os.environ, **env})
        return started_note(pid, log, f"kill -INT {pid}")

    def stop_node(self, node: str) -> str:
        pid = self.detached.pid(node)
        if pid is not None and self.detached.signal(node, signal.SIGINT):
            timer = threading.Timer(
                2.0, lambda: self.detached.signal(node, signal.SIGTERM, only=pid)
            )
            timer.daemon = True
            timer.start()
            return f"SIGINT to pid {pid} (started by racc), SIGTERM in 2 s"
        pids = [p.pid for p in outermost(node_processes(node))]
        for pid in pids:
            threading.Thread(target=terminate, args=(pid, POLITE), daemon=True).start()
        if not pids:
            return "no local process of it found"
        return f"SIGINT, then SIGTERM, to pid {', '.join(str(p) for p in pids)}"

    def kill_node(self, node: str) -> str:
        pid = self.detached.pid(node)
        if pid is not None and self.detached.signal(node, signal.SIGKILL):
            return f"SIGKILL to pid {pid} (started by racc)"
        pids = [p.pid for p in node_processes(node)]
        if not pids and node.strip("/") not in self._graph():
            return "no process of it left: it stopped (the observers will say)"
        return kill_pids(node, pids)

    def _graph(self) -> set[str]:
        session = getattr(self, "session", None)
        return graph_nodes(session) if session is not None else set()

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
        self.detached.reap()


def run_repairer(job: RepairJob, restart: str | None = None, name: str = "racc_repairer") -> None:
    session = Session(name)
    actuator = Ros2Actuator(session, job.launch_file, restart)
    try:  # the nodes racc started are left running: they belong to the robot
        run_repair_node(session, actuator, job, after_tick=actuator.reap)
    finally:
        session.close()
