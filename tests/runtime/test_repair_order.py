"""The right node first (issue 36, goal 5; rac/runtime/repairer/evidence.py), on a chain
of nodes as in the relay graph: a player, then relays each feeding the next.  A node the
observations show not running is restarted first and alone; while a repair settles, the
node below the repaired one is not taken for a new fault.  Both failed before: the player
was restarted beside the crashed relay, and the next relay down after it."""

from __future__ import annotations

import pytest

from rac.diagnosis import Theory
from rac.load.files import load_model
from rac.load.theory import load_theory
from rac.logic import Atom
from rac.observe import Verdict
from rac.pipeline import compile_model
from rac.runtime.repairer import LogEntry, RepairExecutor, Settings
from rac.runtime.repairer.evidence import downstream
from rac.targets import EmitOptions, emit_all

CHAIN = """robot chain
topic /imu : sensor_msgs/Imu @ 50 Hz
topic /imu_1 : sensor_msgs/Imu @ 50 Hz
topic /imu_2 : sensor_msgs/Imu @ 50 Hz
topic /imu_3 : sensor_msgs/Imu @ 50 Hz
node player { publishes /imu }
node relay_1 { subscribes /imu
  publishes /imu_1 from /imu }
node relay_2 { subscribes /imu_1
  publishes /imu_2 from /imu_1 }
node relay_3 { subscribes /imu_2
  publishes /imu_3 from /imu_2 }
"""
NODES = ("player", "relay_1", "relay_2", "relay_3")


@pytest.fixture(scope="module")
def theory(tmp_path_factory: pytest.TempPathFactory) -> Theory:
    out = tmp_path_factory.mktemp("chain")
    (out / "chain.ram").write_text(CHAIN, "utf-8")
    compiled = compile_model(load_model(out / "chain.ram"))
    (out / "model.yaml").write_text(emit_all(compiled, EmitOptions())["model.yaml"], "utf-8")
    return load_theory(str(out / "model.yaml"))


class Rig:
    """The executor on a fake clock; a start or stop shows at once in Θ."""

    def __init__(self, theory: Theory) -> None:
        self.t = 1000.0
        self.log: list[LogEntry] = []
        self.calls: list[tuple[str, str]] = []
        self.ex = RepairExecutor(
            theory,
            "chain",
            self,
            self.log.append,
            clock=lambda: self.t,
            settings=Settings(step_timeout_s=5.0, verify_timeout_s=10.0),
        )
        for node in NODES:
            self.see(f"running({node})")
        for topic in ("imu", "imu_1", "imu_2", "imu_3"):
            self.see(f"ok({topic})")
        self.standing: tuple[tuple[str, ...], ...] = ()
        self.ex.diagnosis(())

    def see(self, text: str, positive: bool = True) -> None:
        predicate, _, rest = text.partition("(")
        atom = Atom(predicate, tuple(rest.rstrip(")").split(",")))
        self.ex.observe(Verdict(self.t, atom, positive))

    def _act(self, action: str, node: str, running: bool) -> str | None:
        self.calls.append((action, node))
        self.see(f"running({node})", running)
        return None

    def stop_node(self, node: str) -> str | None:
        return self._act("stop_node", node, False)

    def kill_node(self, node: str) -> str | None:
        return self._act("kill_node", node, False)

    def start_node(self, node: str) -> str | None:
        return self._act("start_node", node, True)

    def switch(self, device: str, on: bool) -> str | None:
        raise AssertionError("no hardware here")

    def diagnose(self, *diagnoses: tuple[str, ...]) -> None:
        self.standing = tuple(diagnoses)
        self.ex.diagnosis(self.standing)

    def run(self, seconds: float) -> None:
        """Tick every 0.1 s; the engine's heartbeat repeats the diagnosis every second."""
        end = self.t + seconds
        while self.t < end - 1e-9:
            self.t = round(self.t + 0.1, 6)
            if round(self.t * 10) % 10 == 0:
                self.ex.diagnosis(self.standing)
            self.ex.tick()


def test_downstream_follows_the_topics_through_the_chain(theory: Theory) -> None:
    assert downstream(theory, ["relay_1"]) == {"relay_2", "relay_3"}
    assert downstream(theory, ["player"]) == {"relay_1", "relay_2", "relay_3"}
    assert downstream(theory, ["relay_3"]) == frozenset()


def test_a_node_seen_crashed_is_restarted_first_and_alone(theory: Theory) -> None:
    rig = Rig(theory)
    # relay_2 killed; for a moment the player's own topic reads not_ok as well (its
    # observer late), and the smallest diagnosis names both.
    rig.see("running(relay_2)", False)
    for topic in ("imu", "imu_2", "imu_3"):
        rig.see(f"ok({topic})", False)
    rig.diagnose(("player", "relay_2"))
    rig.run(3.0)
    assert rig.calls == [("start_node", "relay_2")]
    (plan,) = [e for e in rig.log if e.action == "plan"]
    assert "the crashed relay_2 first" in plan.message


def test_the_node_below_a_repaired_one_is_left_to_settle(theory: Theory) -> None:
    rig = Rig(theory)
    rig.see("running(relay_1)", False)
    for topic in ("imu_1", "imu_2", "imu_3"):
        rig.see(f"ok({topic})", False)
    rig.diagnose(("relay_1",))
    rig.run(3.0)
    assert rig.calls == [("start_node", "relay_1")]
    # relay_1 is back and its output with it; relay_2 reconnects to it later, so for 3 s
    # the diagnosis names relay_2, then everything is ok again.
    rig.see("ok(imu_1)")
    rig.diagnose(("relay_2",))
    rig.run(3.0)
    for topic in ("imu_2", "imu_3"):
        rig.see(f"ok({topic})")
    rig.diagnose()
    rig.run(5.0)
    assert rig.calls == [("start_node", "relay_1")]
    assert any(e.action == "verify" and "no fault" in e.message for e in rig.log)


def test_a_fault_below_that_outlasts_the_verification_is_repaired(theory: Theory) -> None:
    rig = Rig(theory)
    rig.see("running(relay_1)", False)
    rig.diagnose(("relay_1",))
    rig.run(3.0)
    assert rig.calls == [("start_node", "relay_1")]
    rig.see("ok(imu_1)")
    rig.diagnose(("relay_2",))  # relay_2 really is broken
    rig.run(25.0)
    assert ("stop_node", "relay_2") in rig.calls or ("start_node", "relay_2") in rig.calls
