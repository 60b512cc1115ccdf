"""The repair actions on a live ROS 1 system (the requests of :mod:`rac.runtime.repairer`),
used by the repair node (:mod:`rac.ros1.repairer`) and by a machine's racc agent
(:mod:`rac.ros1.agent`); see the repair node's docstring for what each action does."""

from __future__ import annotations

import os
import signal
import threading
import xmlrpc.client
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any
from urllib.parse import urlparse

from rac.errors import Diagnostic, RacError
from rac.ros1.common import (
    CALLER,
    LOCAL_HOSTS,
    is_local_host,
    master_uri,
    node_uri,
    proxy,
    resolve_pid,
)
from rac.runtime.detached import Detached, kill_pids, started_note
from rac.runtime.guardian import DEFAULT_GONE_S
from rac.runtime.lifetime import Lifetime, launch_process
from rac.runtime.onecopy import Copy, local_copies, names_another_node, prove_gone
from rac.runtime.placement import cmdline, in_own_pid_namespace, listening_pid
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
    """The executor's requests on ROS 1.  Started nodes are detached (:mod:`rac.runtime.
    detached`): they belong to the robot and outlive racc, not the robot (their guardian
    stops them when the robot's launch ends or its master has been gone ``robot_gone_s``).
    A node is started only once its old process is proven gone (:mod:`rac.runtime.
    onecopy`)."""

    def __init__(
        self, rospy: Any, launch_file: str | None, robot_gone_s: float = DEFAULT_GONE_S
    ) -> None:
        from diagnostic_msgs.msg import KeyValue

        self.rospy = rospy
        self.launch_file = launch_file
        self.robot_gone_s = robot_gone_s
        self.entries = load_launch_nodes(launch_file) if launch_file else {}
        self.run_id = str(rospy.get_param("/run_id", "racc"))
        self.detached = Detached()
        self.KeyValue = KeyValue
        self.switches = rospy.Publisher("/board_switch", KeyValue, queue_size=10)
        # A switch request's value as it goes out: sealed by the repairer (rac.runtime.trust).
        self.sealed: Callable[[str, str], str] = lambda device, value: value

    def _entry(self, node: str) -> Any:
        key = "/" + node.lstrip("/")
        entry = self.entries.get(key)
        if entry is None:
            where = self.launch_file or "no launch file (give one with --launch)"
            raise RacError([Diagnostic("RAC111", f"node '{node}' has no entry in {where}")])
        return entry

    def start_node(self, node: str) -> str:
        """The entry's command line and environment as roslaunch makes them, run in a
        session of its own under its guardian, once the old process is proven gone."""
        with self.detached.starting:
            waiting = self.detached.still_starting(node)
            return waiting if waiting is not None else self._start(node)

    def _start(self, node: str) -> str:
        # What roslaunch.nodeprocess.create_node_process computes, without its Process
        # object, which installs signal handlers (and fails off the main thread).
        import roslaunch.core
        import roslaunch.node_args
        import rospkg

        entry = self._entry(node)
        try:
            made = roslaunch.node_args.create_local_process_args(entry, entry.machine)
            env = roslaunch.core.setup_env(entry, entry.machine, master_uri())
        except Exception as err:  # roslaunch raises many kinds for a bad entry
            raise RacError(
                [Diagnostic("RAC111", f"roslaunch cannot make the command of '{node}': {err}")]
            ) from None
        log_dir = Path(rospkg.get_log_dir(env=os.environ)) / self.run_id
        name = node.strip("/").replace("/", "-")
        args = [a for a in made if not a.startswith("__log:=")]
        args.append(f"__log:={log_dir / (name + '-racc.log')}")
        if entry.cwd == "node":
            cwd = os.path.dirname(args[0])
        elif entry.cwd == "cwd":
            cwd = os.getcwd()
        else:
            cwd = rospkg.get_ros_home()
        copies, unseen = self.old_copies(node, env)
        stopped = prove_gone(node, copies, unseen)
        lifetime = Lifetime(
            launch=launch_process(self.launch_file),
            master_uri=env.get("ROS_MASTER_URI") or master_uri(),
            gone_s=self.robot_gone_s,
        )
        pid, log = self.detached.start(node, args, env, cwd, log_dir, lifetime)
        note = started_note(pid, log, f"rosnode kill /{node.lstrip('/')}", lifetime)
        return f"{stopped}; {note}" if stopped else note

    def old_copies(
        self, node: str, env: Mapping[str, str] | None = None
    ) -> tuple[list[Copy], list[str]]:
        """Every live process that may be ``node`` (:mod:`rac.runtime.onecopy`): the one
        racc started, local processes naming it, the local process holding the XML-RPC
        port the master has for it; and why any other cannot be stopped from here (the
        master has it on another machine and its server answers, or does not answer)."""
        copies, unseen = local_copies(node, 1, self.detached.pid(node), env)
        try:
            uri = node_uri(node)
        except (OSError, xmlrpc.client.Error):
            uri = None  # no master: the local processes are all that can be checked
        if uri is None:
            return copies, unseen
        parsed = urlparse(uri)
        host, port = parsed.hostname or "", parsed.port
        if not is_local_host(host):
            try:
                proxy(uri).getPid(CALLER)
                unseen.append(f"the master has it at {uri}, another machine, where it answers")
            except TimeoutError:
                unseen.append(f"the master has it at {uri}, another machine, which does not answer")
            except (OSError, xmlrpc.client.Error):
                pass  # refused: that server is gone
            return copies, unseen
        holder = listening_pid(port) if port else None
        if (
            holder is None
            or holder == os.getpid()
            or any(c.pid == holder for c in copies)
            or names_another_node(cmdline(holder), node)
        ):
            return copies, unseen
        if in_own_pid_namespace(holder):
            copies.append(Copy(holder, f"it holds the XML-RPC port {port} the master has for it"))
        else:
            unseen.append(f"pid {holder} holds its XML-RPC port {port} in another PID namespace")
        return copies, unseen

    def stop_node(self, node: str) -> str:
        """A node racc started: SIGINT to its session (as roslaunch stops a node), SIGTERM
        2 s later.  Any other: XML-RPC shutdown (as rosnode kill), SIGTERM 2 s later.  A
        node that does not stop is killed by the executor after the step time-out."""
        pid = self.detached.pid(node)
        if pid is not None and self.detached.signal(node, signal.SIGINT):
            _later(2.0, lambda: self.detached.signal(node, signal.SIGTERM, only=pid))
            return f"SIGINT to pid {pid} (started by racc)"
        # Only a process proven to be the node's is signalled: the pid a node in a
        # container answers is not one of this host (1 would be the init process).
        found = resolve_pid(node)
        pid = found.pid if found is not None else None
        said = "not reachable over XML-RPC"
        try:
            uri = node_uri(node)
            if uri is not None:
                proxy(uri).shutdown(CALLER, "racc repairer: stop_node")
                said = "asked over XML-RPC to shut down"
        except (OSError, xmlrpc.client.Error):
            pass
        if pid is not None:
            threading.Thread(
                target=terminate, args=(pid, (None, signal.SIGTERM)), kwargs={"grace_s": 2.0}
            ).start()
            return f"{said}; SIGTERM to pid {pid} if it still runs in 2 s"
        return said

    def kill_node(self, node: str) -> str:
        """SIGKILL: to the session racc started, else to the node's local process, found by
        getPid or, for a node that does not answer (frozen), by its XML-RPC port."""
        pid = self.detached.pid(node)
        if pid is not None and self.detached.signal(node, signal.SIGKILL):
            return f"SIGKILL to pid {pid} (started by racc)"
        found = resolve_pid(node)
        pid = found.pid if found is not None else None
        if found is None:
            try:
                uri = node_uri(node)
            except (OSError, xmlrpc.client.Error):
                uri = None
            if uri is None:
                return "it is no longer registered with the master: it stopped"
            parsed = urlparse(uri)
            local = (parsed.hostname or "") in LOCAL_HOSTS or (parsed.hostname or "").startswith(
                "127."
            )
            pid = listening_pid(parsed.port) if local and parsed.port else None
            if local and pid is None:
                return "no process listens on its XML-RPC port: it stopped"
        return kill_pids(node, [pid] if pid is not None else [])

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
        value = self.sealed(device, "on" if on else "off")
        self.switches.publish(self.KeyValue(key=device, value=value))

    def reap(self) -> None:
        self.detached.reap()


def _later(delay_s: float, action: Callable[[], object]) -> None:
    timer = threading.Timer(delay_s, action)
    timer.daemon = True
    timer.start()
