"""The repair actions on a live ROS 2 system (the requests of :mod:`rac.runtime.repairer`),
used by the repair node (:mod:`rac.ros2.repairer`) and by a machine's racc agent
(:mod:`rac.ros2.agent`); see the repair node's docstring for what each action does."""

from __future__ import annotations

import os
import shlex
import signal
import threading
from collections.abc import Callable, Iterable

from rac.errors import Diagnostic, RacError
from rac.ros2.common import Session, graph_nodes, reliable
from rac.ros2.launch import LaunchNode, command_line, load_launch
from rac.runtime.detached import Detached, kill_pids, started_note
from rac.runtime.guardian import DEFAULT_GONE_S
from rac.runtime.lifetime import Lifetime, launch_process, robot_nodes
from rac.runtime.onecopy import local_copies, prove_gone
from rac.runtime.procs import node_processes, outermost, terminate

POLITE = (signal.SIGINT, signal.SIGTERM)  # the executor kills after the step time-out


class Ros2Actuator:
    """The executor's requests on ROS 2.  A started node belongs to the robot: detached
    from racc, under a guardian that stops it when the robot's launch ends or all of the
    robot's other local nodes (``robot``, and the launch file's) have been gone for
    ``robot_gone_s``; it is started only once its old process is proven gone."""

    def __init__(
        self,
        session: Session,
        launch_file: str | None,
        restart: str | None,
        robot: Iterable[str] = (),
        robot_gone_s: float = DEFAULT_GONE_S,
    ) -> None:
        from diagnostic_msgs.msg import KeyValue

        self.session = session
        self.launch_file, self.restart = launch_file, restart
        nodes = load_launch(launch_file) if launch_file else []
        self.entries: dict[str, LaunchNode] = {n.key: n for n in nodes if n.name}
        self.robot = robot_nodes([*robot, *self.entries])
        self.robot_gone_s = robot_gone_s
        self.detached = Detached()
        self.KeyValue = KeyValue
        self.switches = session.node.create_publisher(KeyValue, "/board_switch", reliable(10))
        # A switch request's value as it goes out: sealed by the repairer (rac.runtime.trust).
        self.sealed: Callable[[str, str], str] = lambda device, value: value

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
        with self.detached.starting:
            waiting = self.detached.still_starting(node)
            if waiting is not None:
                return waiting
            env = {**os.environ, **env}
            copies, unseen = local_copies(node, 2, self.detached.pid(node), env)
            stopped = prove_gone(node, copies, unseen)
            lifetime = Lifetime(
                launch=launch_process(self.launch_file),
                others=self.robot,
                gone_s=self.robot_gone_s,
            )
            pid, log = self.detached.start(node, args, {**os.environ, **env}, lifetime=lifetime)
        note = started_note(pid, log, f"kill -INT {pid}", lifetime)
        return f"{stopped}; {note}" if stopped else note

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
        value = self.sealed(device, "on" if on else "off")
        self.switches.publish(self.KeyValue(key=device, value=value))

    def reap(self) -> None:
        self.detached.reap()
