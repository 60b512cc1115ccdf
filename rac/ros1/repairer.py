"""The repair node (``racc repairer``): Algorithm 11 executed on a live ROS 1 system.

The executor (:mod:`rac.runtime.repairer`) decides; this node carries out its requests:

- start_node(n): the entry named ``n`` in the user's launch file (``--launch``), started
  through roslaunch's Python API (``roslaunch.scriptapi.ROSLaunch``) with its package,
  type, args, remappings and environment; the file's parameters are already on the
  parameter server from the user's own roslaunch;
- stop_node(n): a node this repairer started is stopped by roslaunch; any other is asked to
  shut down over its XML-RPC API (as ``rosnode kill`` does), then sent SIGTERM;
- shutdown(d) / power_up(d): a request on ``/board_switch`` to the board client node.
"""

from __future__ import annotations

import signal
import threading
from pathlib import Path
from typing import Any

from rac.errors import Diagnostic, RacError
from rac.ros1.agent import routed_actuator
from rac.ros1.common import CALLER, Ros1Bus, node_uri, proxy, resolve_pid
from rac.runtime.nodes import RepairJob, run_repair_node
from rac.runtime.procs import terminate


def load_launch_nodes(path: str) -> dict[str, Any]:
    """Node entries of a launch file by resolved name ("/ns/name" -> roslaunch Node)."""
    import roslaunch.config

    if not Path(path).is_file():
        raise RacError([Diagnostic("RAC059", f"{path}: no such launch file")])
    try:
        config = roslaunch.config.load_config_default([path], None, verbose=False)
    except Exception as err:  # roslaunch raises many kinds for a bad file
        raise RacError(
            [Diagnostic("RAC059", f"{path}: cannot load the launch file: {err}")]
        ) from None
    out: dict[str, Any] = {}
    for node in config.nodes:
        ns = node.namespace if node.namespace.endswith("/") else node.namespace + "/"
        out[f"{ns}{node.name}"] = node
    return out


class Ros1Actuator:
    def __init__(self, rospy: Any, launch_file: str | None) -> None:
        import roslaunch.scriptapi
        from diagnostic_msgs.msg import KeyValue

        self.rospy = rospy
        self.launch_file = launch_file
        self.entries = load_launch_nodes(launch_file) if launch_file else {}
        self.launch = roslaunch.scriptapi.ROSLaunch()  # the main thread: roslaunch wants it
        self.launch.start()
        self.started: dict[str, Any] = {}
        self.KeyValue = KeyValue
        self.switches = rospy.Publisher("/board_switch", KeyValue, queue_size=10)

    def _entry(self, node: str) -> Any:
        key = "/" + node.lstrip("/")
        entry = self.entries.get(key)
        if entry is None:
            where = self.launch_file or "no launch file (give one with --launch)"
            raise RacError([Diagnostic("RAC111", f"node '{node}' has no entry in {where}")])
        return entry

    def start_node(self, node: str) -> None:
        entry = self._entry(node)
        try:
            self.started[node] = self.launch.launch(entry)
        except Exception as err:
            raise RacError(
                [Diagnostic("RAC111", f"roslaunch cannot start '{node}': {err}")]
            ) from None

    def stop_node(self, node: str) -> None:
        proc = self.started.pop(node, None)
        if proc is not None and proc.is_alive():
            proc.stop()
            return
        # Only a process proven to be the node's is signalled: the pid a node in a
        # container answers is not one of this host (1 would be the init process).
        found = resolve_pid(node)
        pid = found.pid if found is not None else None
        try:
            uri = node_uri(node)
            if uri is not None:
                proxy(uri).shutdown(CALLER, "racc repairer: stop_node")
        except OSError:
            pass
        if pid is not None:
            threading.Thread(
                target=terminate, args=(pid, (None, signal.SIGTERM, signal.SIGKILL)), daemon=True
            ).start()

    def switch(self, device: str, on: bool) -> None:
        if self.switches.get_num_connections() == 0:
            raise RacError(
                [
                    Diagnostic(
                        "RAC114",
                        "no board client listens on /board_switch",
                        hint="start it with 'racc board-client' (compiled launch files do)",
                    )
                ]
            )
        self.switches.publish(self.KeyValue(key=device, value="on" if on else "off"))

    def shutdown(self) -> None:
        self.launch.stop()


def run_repairer(job: RepairJob, name: str = "racc_repairer") -> None:
    bus = Ros1Bus(name)
    actuator = Ros1Actuator(bus.rospy, job.launch_file)
    try:
        run_repair_node(bus, routed_actuator(bus.rospy, job, actuator), job)
    finally:
        actuator.shutdown()
