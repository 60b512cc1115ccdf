"""Repairs on the right machine (issue 28): a node is restarted where it runs.

The repairer runs on one machine (``--machine``, by default the robot's first).  A node of
another machine is restarted by the racc agent of that machine, its observer host (``racc
observe --machine NAME --launch FILE``): the repairer publishes the request on
``/racc_agent/NAME`` (``diagnostic_msgs/KeyValue``: key the action, ``start_node`` or
``stop_node``, value the node) and the agent carries it out with its machine's launch file,
as the repairer would locally.  Like Kubernetes' kubelet, the agent that watches a
machine's processes is the one that restarts them; no ssh and no env-loader are needed, and
it works the same on ROS 2, which has no remote launch.  The executor verifies the effect
in the observations, as for any step.

The agent acts only on the requests the repairer sealed (:mod:`rac.runtime.trust`; the
transport checks the seal), and only on its machine's nodes of the model: a request for a
node the model does not place there, or for one of racc's own nodes, is refused and
reported.

A node in a container is restarted by restarting its container: ``docker restart NAME``
(or ``podman``) on the node's machine, and stopped by ``docker stop NAME``.  A request no
agent listens to, or a container command that fails, is RAC143.
"""

from __future__ import annotations

import queue
import shutil
import subprocess
import threading
import time
from collections.abc import Callable, Mapping, Sequence

from rac.errors import Diagnostic, RacError
from rac.runtime.repairer import Actuator, LogEntry

AGENT_TOPIC = "/racc_agent/{machine}"
ACTIONS = ("start_node", "stop_node", "kill_node")
CONTAINER_VERBS = {"start_node": "restart", "stop_node": "stop", "kill_node": "kill"}
CONTAINER_TIMEOUT_S = 30.0
RACC_PREFIX = "racc_"  # racc's own nodes: racc_observer, racc_engine, racc_repairer...

Placement = tuple[str | None, str | None]  # (machine, "runtime:NAME" container)


def agent_topic(machine: str) -> str:
    return AGENT_TOPIC.format(machine=machine)


def agent_started(machine: str, launch: str | None) -> str:
    """The observer host's log line when its machine's agent is up."""
    return (
        f"racc agent {machine}: restarts its nodes on {agent_topic(machine)} "
        f"(launch file {launch or 'none'})"
    )


def container_command(action: str, container: str) -> list[str]:
    """``docker restart NAME`` to start a contained node, ``docker stop NAME`` to stop it,
    ``docker kill NAME`` to kill it."""
    runtime, _, name = container.partition(":")
    return [runtime, CONTAINER_VERBS[action], name]


def run_container(action: str, node: str, container: str) -> None:
    """The container command, waited for; RAC143 when it cannot be run or fails."""
    argv = container_command(action, container)
    if shutil.which(argv[0]) is None:
        raise _unrestartable(node, f"'{argv[0]}' is not installed here", argv)
    try:
        done = subprocess.run(
            argv, capture_output=True, text=True, timeout=CONTAINER_TIMEOUT_S, check=False
        )
    except (OSError, subprocess.TimeoutExpired) as err:
        raise _unrestartable(node, str(err), argv) from None
    if done.returncode != 0:
        why = (done.stderr or done.stdout).strip().splitlines()[-1:] or [f"exit {done.returncode}"]
        raise _unrestartable(node, why[0], argv)


def _unrestartable(node: str, why: str, argv: Sequence[str]) -> RacError:
    return RacError(
        [
            Diagnostic(
                "RAC143",
                f"cannot {'restart' if argv[1] == 'restart' else 'stop'} '{node}' "
                f"({' '.join(argv)}): {why}",
                hint="install the container runtime the model names on that machine",
            )
        ]
    )


def no_agent(machine: str, node: str) -> RacError:
    return RacError(
        [
            Diagnostic(
                "RAC143",
                f"no racc agent of machine '{machine}' listens on {agent_topic(machine)} "
                f"to restart '{node}'",
                hint=f"start 'racc observe OBSERVERS --machine {machine} --launch FILE' there "
                "(the compiled observers.launch does)",
            )
        ]
    )


class RoutedActuator:
    """The repairer's actuator: a node of this machine through ``local`` (or its container
    command), a node of another machine through ``ask(machine, action, node)``."""

    def __init__(
        self,
        local: Actuator,
        placements: Mapping[str, Placement],
        here: str | None,
        ask: Callable[[str, str, str], None],
    ) -> None:
        self.local, self.placements, self.here, self.ask = local, placements, here, ask

    def _do(self, action: str, node: str) -> str | None:
        machine, container = self.placements.get(node.strip("/"), (None, None))
        if machine is not None and self.here is not None and machine != self.here:
            self.ask(machine, action, node)
            return f"asked the racc agent of machine {machine}"
        if container is not None:
            run_container(action, node, container)
            return " ".join(container_command(action, container))
        note: str | None = getattr(self.local, action)(node)
        return note

    def stop_node(self, node: str) -> str | None:
        return self._do("stop_node", node)

    def kill_node(self, node: str) -> str | None:
        return self._do("kill_node", node)

    def start_node(self, node: str) -> str | None:
        return self._do("start_node", node)

    def switch(self, device: str, on: bool) -> str | None:
        return self.local.switch(device, on)


class Agent:
    """The racc agent of one machine, in its observer host.  Requests arrive on any thread
    and are carried out one at a time on the agent's own thread: a ``docker restart`` may
    take tens of seconds, and the host's sampling loop must not stall meanwhile (a stalled
    host is starved, then lost, and the repair could not be verified).  What each request
    came to is a :class:`LogEntry` (``agent``), for the host's log and ``/repair_log``:
    a failure shows there, not only after the repairer's step time-out."""

    def __init__(
        self,
        machine: str,
        placements: Mapping[str, Placement],
        local: Actuator | None,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.machine, self.placements, self.local, self.clock = machine, placements, local, clock
        self._requests: queue.Queue[tuple[str, str, float]] = queue.Queue()
        self._reports: list[LogEntry] = []
        self._lock = threading.Lock()
        self._idle = threading.Condition(self._lock)
        self._busy = 0  # requests taken and not yet reported
        self._worker: threading.Thread | None = None

    def request(self, action: str, node: str) -> None:
        with self._lock:
            self._busy += 1
            if self._worker is None:  # daemon: a request under way does not hold the exit
                self._worker = threading.Thread(target=self._work, name="racc-agent", daemon=True)
                self._worker.start()
        self._requests.put((action, node, self.clock()))

    def reports(self) -> list[LogEntry]:
        """What the requests carried out since the last call came to, in order."""
        with self._lock:
            done, self._reports = self._reports, []
        return done

    def wait_idle(self, timeout: float) -> bool:
        """Wait until every request so far is carried out; False on the time-out."""
        with self._idle:
            return self._idle.wait_for(lambda: self._busy == 0, timeout)

    def _work(self) -> None:
        while True:
            action, node, asked = self._requests.get()
            try:
                entry = self._carry_out(action, node, asked)
            except Exception as err:  # an actuator's own failure: reported, the agent lives on
                entry = self._entry(2, action, node, f"failed: {type(err).__name__}: {err}")
            with self._idle:
                self._reports.append(entry)
                self._busy -= 1
                self._idle.notify_all()

    def _entry(self, level: int, action: str, node: str, outcome: str) -> LogEntry:
        message = f"{action}({node}) on machine {self.machine}: {outcome}"
        return LogEntry(self.clock(), level, "agent", node, message)

    def _carry_out(self, action: str, node: str, asked: float) -> LogEntry:
        if action not in ACTIONS:
            return self._entry(1, action, node, "refused: unknown action")
        if node.strip("/").startswith(RACC_PREFIX):
            return self._entry(1, action, node, "refused: racc never acts on its own nodes")
        if node.strip("/") not in self.placements:
            return self._entry(
                1,
                action,
                node,
                f"refused: '{node}' is no node of machine {self.machine} in the model",
            )
        where, container = self.placements[node.strip("/")]
        if where is not None and where != self.machine:
            return self._entry(1, action, node, f"refused: '{node}' runs on {where}")
        note: str | None = None
        try:
            if container is not None:
                run_container(action, node, container)
            elif self.local is not None:
                # The local actuator proves the old process gone before it starts the node
                # (rac.runtime.onecopy), here on the node's machine as for the repairer's.
                note = getattr(self.local, action)(node)
            else:
                return self._entry(2, action, node, "failed: no --launch file to start it from")
        except RacError as err:
            first = err.diagnostics[0]
            return self._entry(2, action, node, f"failed: {first.code} {first.message}")
        done = f"done {self.clock() - asked:.2f} s after the request"
        return self._entry(0, action, node, f"{done}: {note}" if note else done)
