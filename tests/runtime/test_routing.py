"""Several machines without ROS (issue 28): where each observer runs, which host the engine
hears, what happens when one goes, and where a node is restarted (rac.passes.machines,
rac.runtime.hosts, rac.runtime.routing)."""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

import pytest

from rac.errors import Diagnostic, RacError
from rac.logic import Atom
from rac.parse import parse_ram
from rac.passes.machines import machines_of, node_placements, on_machine, spec_machine
from rac.pipeline import compile_model
from rac.runtime.diagnoser import EngineLoop
from rac.runtime.hosts import HostWatch
from rac.runtime.routing import Agent, RoutedActuator, container_command, run_container
from rac.runtime.status import Row
from rac.targets import EmitOptions, emit_all

DUO = """robot duo
machine base address 10.0.0.1
machine arm address 10.0.0.2
hardware cam switchable channel 1
topic /chatter @ 10 Hz
topic /image @ 5 Hz
node talker on arm { publishes /chatter; limits cpu 50 % }
node camera drives cam in container cam_1 via podman { publishes /image; reports cam }
node listener { subscribes /chatter, /image }
"""


def _compiled(text: str = DUO):  # type: ignore[no-untyped-def]
    return compile_model(parse_ram(text, "duo.ram"))


def test_each_observer_runs_on_its_machine() -> None:
    specs = _compiled().observers
    where = {s.name: spec_machine(s) for s in specs}
    assert where["talker_nobs"] == where["talker_cpu_pobs"] == "arm"
    assert where["chatter_gobs"] == "arm"  # where its publisher runs
    assert where["camera_nobs"] == where["image_gobs"] == "base"  # no 'on': the first machine
    assert where["board_hobs"] == where["cam_dobs"] == "base"
    assert machines_of(specs) == ("base", "arm")
    assert {s.name for s in on_machine(specs, "arm")} == {
        "talker_nobs",
        "talker_cpu_pobs",
        "chatter_gobs",
    }
    assert on_machine(specs, None) == specs
    assert node_placements(specs)["camera"] == ("base", "podman:cam_1")


def test_a_model_without_machines_compiles_as_before() -> None:
    text = "robot r\ntopic /t @ 10 Hz\nnode n { publishes /t }\n"
    compiled = _compiled(text)
    assert all(spec_machine(s) is None for s in compiled.observers)
    launch = emit_all(compiled, EmitOptions())["observers.launch"]
    assert "<machine" not in launch and 'name="racc_observer"' in launch


def test_the_launch_file_starts_one_host_per_machine() -> None:
    launch = emit_all(_compiled(), EmitOptions())["observers.launch"]
    assert '<machine name="base" address="10.0.0.1"' in launch and 'default="true"' in launch
    assert '<machine name="arm" address="10.0.0.2"' in launch
    assert 'machine="arm" pkg="racc" type="observe" name="racc_observer_arm"' in launch
    assert "--machine arm --launch=$(arg robot_launch)" in launch
    assert '--machine base --secret=$(arg secret)"' in launch  # the repairer: the first machine
    assert "--hosts racc_observer_base,racc_observer_arm" in launch


class Local:
    def __init__(self) -> None:
        self.calls: list[tuple[str, str]] = []

    def start_node(self, node: str) -> None:
        self.calls.append(("start_node", node))

    def stop_node(self, node: str) -> None:
        self.calls.append(("stop_node", node))

    def kill_node(self, node: str) -> None:
        self.calls.append(("kill_node", node))

    def switch(self, device: str, on: bool) -> None:
        self.calls.append(("switch", f"{device} {'on' if on else 'off'}"))


def _fake_runtime(tmp: Path, name: str, code: int = 0) -> Path:
    script = tmp / name
    script.write_text(f'#!/bin/sh\necho "$@" >> {tmp}/calls\nexit {code}\n', encoding="utf-8")
    script.chmod(0o755)
    return tmp / "calls"


def test_a_node_is_restarted_where_it_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    calls = _fake_runtime(tmp_path, "podman")
    monkeypatch.setenv("PATH", f"{tmp_path}:{os.environ['PATH']}")
    local, asked = Local(), []
    placements = node_placements(_compiled().observers)
    routed = RoutedActuator(local, placements, "base", lambda *a: asked.append(a))
    routed.start_node("talker")
    routed.start_node("listener")
    routed.stop_node("camera")
    routed.start_node("camera")
    assert asked == [("arm", "start_node", "talker")]
    routed.switch("lidar", False)  # the board is this machine's
    assert local.calls == [("start_node", "listener"), ("switch", "lidar off")]
    assert calls.read_text().split("\n")[:2] == ["stop cam_1", "restart cam_1"]


def test_a_container_that_cannot_be_restarted_is_rac143(tmp_path: Path) -> None:
    assert container_command("start_node", "docker:cam") == ["docker", "restart", "cam"]
    with pytest.raises(RacError) as err:
        run_container("start_node", "camera", "no_such_runtime_here:cam")
    assert err.value.diagnostics[0].code == "RAC143"
    _fake_runtime(tmp_path, "failing", code=1)
    with pytest.raises(RacError) as err:
        run_container("start_node", "camera", f"{tmp_path / 'failing'}:cam")
    assert err.value.diagnostics[0].code == "RAC143"


def test_the_agent_restarts_only_the_nodes_of_its_machine() -> None:
    local = Local()
    agent = Agent("arm", node_placements(_compiled().observers), local)
    agent.request("start_node", "talker")
    agent.request("start_node", "listener")  # runs on base
    agent.request("reboot", "talker")
    assert agent.wait_idle(5.0)
    reports = agent.reports()
    assert local.calls == [("start_node", "talker")]
    assert [(r.level, r.action, r.target) for r in reports] == [
        (0, "agent", "talker"),
        (1, "agent", "listener"),
        (1, "agent", "talker"),
    ]
    assert reports[0].message.startswith("start_node(talker) on machine arm: done")
    assert "runs on base" in reports[1].message
    assert agent.reports() == []  # each report once
    bare = Agent("arm", node_placements(_compiled().observers), None)
    bare.request("start_node", "talker")
    assert bare.wait_idle(5.0)
    assert bare.reports()[0].level == 2  # no launch file to start it from


def test_the_agent_never_acts_on_racc_or_on_a_node_outside_the_model() -> None:
    # Issue 34: /racc_agent/arm with stop_node of /rosout (not in the model) or of
    # racc_engine stopped them; now each is refused and reported, and nothing is done.
    local = Local()
    agent = Agent("arm", node_placements(_compiled().observers), local)
    for node in ("racc_engine", "/racc_repairer", "rosout", "/rosout", "nobody"):
        agent.request("stop_node", node)
    assert agent.wait_idle(5.0)
    reports = agent.reports()
    assert local.calls == []
    assert [r.level for r in reports] == [1] * 5
    assert "racc never acts on its own nodes" in reports[0].message
    assert "is no node of machine arm in the model" in reports[2].message


def test_the_agent_reports_what_its_start_came_to_and_refuses_a_second_copy() -> None:
    """The agent's actuator proves the old process gone on its own machine (rac.runtime.
    onecopy): a copy it stopped first is in its report; one it cannot stop fails the
    request with the actuator's code, and nothing is started."""

    class Proving(Local):
        def start_node(self, node: str) -> str:  # type: ignore[override]
            self.calls.append(("start_node", node))
            return "the old process pid 41200 of talker was still alive: stopped it first"

    class Refusing(Local):
        def start_node(self, node: str) -> None:
            raise RacError([Diagnostic("RAC156", f"not starting '{node}': never two copies")])

    placements = node_placements(_compiled().observers)
    agent = Agent("arm", placements, Proving())
    agent.request("start_node", "talker")
    assert agent.wait_idle(5.0)
    (done,) = agent.reports()
    assert done.level == 0 and "stopped it first" in done.message, done.message
    refusing = Refusing()
    agent = Agent("arm", placements, refusing)
    agent.request("start_node", "talker")
    assert agent.wait_idle(5.0)
    (failed,) = agent.reports()
    assert failed.level == 2 and "failed: RAC156" in failed.message
    assert refusing.calls == []


def test_the_agents_work_does_not_hold_up_its_host_and_failures_are_reported(
    tmp_path: Path,
) -> None:
    """A slow container command runs on the agent's thread: the host's loop, which drains
    the reports each tick, gets none meanwhile and is not held up; a failing one is an
    ERROR report with RAC143, in epoch time like every racc node's log."""
    gate = threading.Event()

    class Slow(Local):
        def start_node(self, node: str) -> None:
            gate.wait(10.0)
            super().start_node(node)

    local = Slow()
    agent = Agent("arm", node_placements(_compiled().observers), local)
    agent.request("start_node", "talker")
    began = time.monotonic()
    assert agent.reports() == []
    assert not agent.wait_idle(0.2)
    assert time.monotonic() - began < 1.0
    gate.set()
    assert agent.wait_idle(5.0)
    (done,) = agent.reports()
    assert done.level == 0 and abs(done.t - time.time()) < 5.0
    _fake_runtime(tmp_path, "failing", code=1)
    placements = {"talker": ("arm", f"{tmp_path / 'failing'}:cam")}
    failing = Agent("arm", placements, None)
    failing.request("start_node", "talker")
    assert failing.wait_idle(10.0)
    (failed,) = failing.reports()
    assert failed.level == 2 and "failed: RAC143" in failed.message
    assert failed.row().name == "agent" and failed.row().hardware_id == "talker"


def test_a_lost_host_has_its_atoms_unknown(tmp_path: Path) -> None:
    watch = HostWatch(lost_after_s=5.0)
    atom = Atom("running", ("talker",))
    assert not watch.heard_from("racc_observer_arm", [atom], 0.0)
    assert watch.newly_lost(4.0) == []
    assert watch.newly_lost(5.5) == [("racc_observer_arm", frozenset({atom}))]
    assert watch.rows("engine", 6.0)[0].level == 2
    assert watch.heard_from("racc_observer_arm", [atom], 7.0)  # back
    # In the engine: a not_running from the lost host no longer counts as a fault.
    logged: list[str] = []
    engine = _engine(tmp_path, logged, host_lost_s=5.0)
    row = Row("running(talker)", 2, "not_running(talker)", "talker_nobs", (("host", "h_arm"),))
    engine.observation_rows([row], 100.0)
    tick = engine.step(100.0)
    assert tick is not None and tick.result.diagnoses == (("talker",),)
    tick = engine.step(106.0)
    assert tick is not None and tick.result.consistent
    assert any("observer host h_arm lost" in line for line in logged)
    assert tick.hosts[0].level == 2 and "unknown" in tick.hosts[0].message


def test_an_engine_that_falls_behind_says_so_and_when_it_has_caught_up(tmp_path: Path) -> None:
    """Observations read long after they were sealed (the engine's queue of arrays grew):
    logged and a WARN row, never silent; a host's clock that is off by seconds is not."""
    logged: list[str] = []
    engine = _engine(tmp_path, logged)
    row = Row("running(talker)", 0, "running(talker)", "talker_nobs", (("host", "h_arm"),))
    # the host's clock is 4 s behind the engine's, and its arrays come at once
    for t in (100.0, 101.0, 102.0):
        engine.observation_rows([row], t, ("h_arm", t - 4.0))
        tick = engine.step(t)
        assert tick is not None
        assert tick.hosts[-1].level == 0, tick.hosts
    # then each array is read 3 s after it was sent
    for t in (103.0, 104.0):
        engine.observation_rows([row], t, ("h_arm", t - 7.0))
        tick = engine.step(t)
        assert tick is not None
        pace = tick.hosts[-1]
        assert pace.name == "racc_engine: pace" and pace.level == 1, pace
        assert "behind: observations read 3.0 s late" in pace.message
    engine.observation_rows([row], 105.0, ("h_arm", 101.0))
    tick = engine.step(105.0)
    assert tick is not None and tick.hosts[-1].level == 0
    assert sum("engine behind" in line for line in logged) == 1
    assert any("engine caught up, after 2.0 s behind" in line for line in logged)


def _engine(tmp_path: Path, logged: list[str], host_lost_s: float = 5.0) -> EngineLoop:
    """The engine of the two-machine model, logging into ``logged``."""
    from rac.load.theory import load_theory

    build = tmp_path / "build"
    build.mkdir()
    for name, text in emit_all(_compiled(), EmitOptions()).items():
        (build / name).write_text(text, encoding="utf-8")
    return EngineLoop(
        str(build / "model.yaml"),
        load_theory,
        "duo",
        "racc_engine",
        lambda level, text: logged.append(text),
        host_lost_s=host_lost_s,
    )
