"""racc's seals (rac.runtime.trust): what a gate admits and what it refuses."""

from __future__ import annotations

import pytest

from rac.passes.observers import BOARD_TOPIC
from rac.runtime.status import DIAGNOSIS, OBSERVATIONS, Row
from rac.runtime.trust import (
    AGENT,
    BOARD_SWITCH,
    CONFIRM,
    ENGINE,
    OBSERVER,
    OPERATOR,
    REPAIRER,
    Admitted,
    Gate,
    Refused,
    Sealer,
    Trust,
    confirm_body,
    read_confirm,
    rows_body,
    split_text,
)

KEY = bytes(range(32))
ROWS = [Row("running(talker)", 0, "running(talker)", "talker_nobs", (("since", "1.000"),))]


class Clock:
    def __init__(self, t: float = 1000.0) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t


def gate_and_sealer(purpose: str, role: str, clock: Clock) -> tuple[Gate, Sealer]:
    return Gate(KEY, purpose, clock=clock), Sealer(KEY, role, "racc_x", clock)


def test_a_sealed_array_is_admitted_once() -> None:
    clock = Clock()
    gate, sealer = gate_and_sealer(OBSERVATIONS, OBSERVER, clock)
    clock.t += 0.5
    seal = str(sealer.seal(OBSERVATIONS, rows_body(ROWS)))
    assert isinstance(gate.admit(seal, rows_body(ROWS)), Admitted)
    replayed = gate.admit(seal, rows_body(ROWS))
    assert isinstance(replayed, Refused) and replayed.reason.startswith("replayed")


@pytest.mark.parametrize(
    "what",
    ["unsealed", "other key", "altered rows", "other purpose", "other role", "stale", "future"],
)
def test_what_a_gate_refuses(what: str) -> None:
    clock = Clock()
    gate = Gate(KEY, OBSERVATIONS, clock=clock)
    clock.t += 1.0
    key, purpose, role, rows = KEY, OBSERVATIONS, OBSERVER, ROWS
    if what == "other key":
        key = bytes(32)
    if what == "other purpose":
        purpose = DIAGNOSIS
    if what == "other role":
        role = REPAIRER
    sealer = Sealer(key, role, "racc_x", clock)
    seal = "" if what == "unsealed" else str(sealer.seal(purpose, rows_body(rows)))
    if what == "altered rows":
        rows = [Row("running(talker)", 2, "not_running(talker)", "talker_nobs")]
    if what == "stale":
        clock.t += 30.0
    if what == "future":
        seal = str(
            Sealer(key, role, "racc_x", lambda: clock.t + 30.0).seal(purpose, rows_body(rows))
        )
    verdict = gate.admit(seal, rows_body(rows))
    assert isinstance(verdict, Refused), what


def test_a_message_sealed_before_the_receiver_started_is_a_replay() -> None:
    clock = Clock()
    sealer = Sealer(KEY, OBSERVER, "racc_x", clock)
    old = str(sealer.seal(OBSERVATIONS, rows_body(ROWS)))
    clock.t += 1.0
    gate = Gate(KEY, OBSERVATIONS, clock=clock)  # the receiver restarted since
    verdict = gate.admit(old, rows_body(ROWS))
    assert isinstance(verdict, Refused) and "before this node started" in verdict.reason


def test_only_the_senders_a_launch_names() -> None:
    clock = Clock()
    gate = Gate(KEY, OBSERVATIONS, senders=("racc_observer_base",), clock=clock)
    clock.t += 1
    named = Sealer(KEY, OBSERVER, "racc_observer_base", clock).seal(OBSERVATIONS, b"x")
    other = Sealer(KEY, OBSERVER, "racc_observer_arm", clock).seal(OBSERVATIONS, b"x")
    assert isinstance(gate.admit(str(named), b"x"), Admitted)
    assert isinstance(gate.admit(str(other), b"x"), Refused)


@pytest.mark.parametrize(
    ("purpose", "role"),
    [
        (OBSERVATIONS, OBSERVER),
        (DIAGNOSIS, ENGINE),
        (CONFIRM, OPERATOR),
        (BOARD_SWITCH, REPAIRER),
        (BOARD_TOPIC, "board_client"),
        (AGENT + "arm", REPAIRER),
    ],
)
def test_each_purpose_admits_its_role_alone(purpose: str, role: str) -> None:
    for other in (OBSERVER, ENGINE, REPAIRER, OPERATOR, "board_client"):
        clock = Clock()
        gate = Gate(KEY, purpose, clock=clock)
        clock.t += 1
        seal = Sealer(KEY, other, "racc_x", clock).seal(purpose, b"body")
        assert isinstance(gate.admit(str(seal), b"body"), Admitted) == (other == role)


def test_a_key_values_seal_covers_its_key() -> None:
    # An agent request's action and a switch's device are the key of a KeyValue: a sealed
    # "start_node talker" cannot be turned into "stop_node talker".
    logged: list[str] = []
    clock = Clock()
    repairer = Trust(KEY, REPAIRER, "racc_repairer", lambda level, text: None, clock)
    agent = Trust(KEY, OBSERVER, "racc_observer_arm", lambda lv, text: logged.append(text), clock)
    gate = agent.gate(AGENT + "arm")
    clock.t += 1
    value = repairer.seal_kv(AGENT + "arm", "start_node", "talker")
    assert split_text(value)[0] == "talker"
    assert agent.check_kv("/racc_agent/arm", gate, "stop_node", value) is None
    assert agent.check_kv("/racc_agent/arm", gate, "start_node", value) == (
        "talker",
        "racc_repairer",
    )
    assert len(logged) == 1 and "bad seal" in logged[0]


def test_refusals_are_logged_once_and_counted() -> None:
    logged: list[str] = []
    clock = Clock()
    trust = Trust(KEY, ENGINE, "racc_engine", lambda level, text: logged.append(text), clock)
    gate = trust.gate(OBSERVATIONS)
    for _ in range(5):
        assert not trust.check_rows(OBSERVATIONS, gate, "", ROWS)
    trust.refuse("/intruder", "/imu_data", "not a publisher of /imu_data in the model")
    assert len(logged) == 2
    row = trust.row()
    assert row.level == 1 and "unsealed (5x" in row.message and "/intruder" in row.message


def test_a_confirmation_names_its_plan_and_run() -> None:
    assert read_confirm(confirm_body("3", "ab12")) == ("3", "ab12")
    assert read_confirm("3") == ("3", "")
    assert read_confirm(" plan 3 ") == ("plan 3", "")
