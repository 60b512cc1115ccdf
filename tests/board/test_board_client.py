"""The client controller (Algorithms 13-14, bounded) and plan execution over loopback."""

from __future__ import annotations

import asyncio
import socket
from collections.abc import Awaitable, Callable
from typing import TypeVar

import pytest

from rac.board.channels import ChannelMap, hobs_literals, resolve_target
from rac.board.client import BoardAddress, BoardClient, ClientSettings, parse_address
from rac.board.execute import (
    NodeCommands,
    execute_plan,
    parse_node_commands,
    suggested_commands,
)
from rac.board.sim import BoardSimulator
from rac.board.state import Fault
from rac.errors import RacError

T = TypeVar("T")
TEDUSAR = ChannelMap(((1, "jaguar"), (2, "hokuyo"), (3, "laser_alignment")))
FAST = ClientSettings(hz=20, timeout_s=1.0, retries=2, reconnects=2)


def run(test: Callable[[BoardSimulator, BoardAddress], Awaitable[T]], limit_s: float = 10.0) -> T:
    async def main() -> T:
        sim = BoardSimulator(TEDUSAR, 10)
        port, _ = await sim.start(control_port=None)
        try:
            return await asyncio.wait_for(test(sim, BoardAddress("127.0.0.1", port)), limit_s)
        finally:
            await sim.close()

    return asyncio.run(main())


def codes(err: pytest.ExceptionInfo[RacError]) -> list[str]:
    return [d.code for d in err.value.diagnostics]


def test_client_reads_switches_and_sees_the_new_state() -> None:
    async def test(sim: BoardSimulator, address: BoardAddress) -> None:
        async with BoardClient(address, FAST) as board:
            assert board.channel_count == 10
            msr = await board.measure()
            assert hobs_literals(TEDUSAR, msr) == (
                "on(jaguar)",
                "on(hokuyo)",
                "on(laser_alignment)",
            )
            await board.switch(2, False)
            msr = await board.wait_for_state(2, False, 1.0)
            assert hobs_literals(TEDUSAR, msr)[1] == "not_on(hokuyo)"
            assert not sim.state.channels[1].on

    run(test)


def test_refused_command_is_retried_a_bounded_number_of_times() -> None:
    async def test(sim: BoardSimulator, address: BoardAddress) -> None:
        async with BoardClient(address, FAST) as board:
            with pytest.raises(RacError, match="refused Switch 3 times") as caught:
                await board.switch(42, True)
            assert codes(caught) == ["RAC091"]

    run(test)


def test_a_stuck_relay_fails_clearly() -> None:
    async def test(sim: BoardSimulator, address: BoardAddress) -> None:
        sim.state.inject(1, Fault.JAMMED)
        async with BoardClient(address, FAST) as board:
            await board.switch(1, False)
            with pytest.raises(RacError, match="did not show channel 1 off") as caught:
                await board.wait_for_state(1, False, 0.3)
            assert codes(caught) == ["RAC093"]

    run(test)


def test_client_reconnects_after_the_board_drops_it() -> None:
    async def test(sim: BoardSimulator, address: BoardAddress) -> None:
        async with BoardClient(address, FAST) as board:
            await board.measure()
            for session in list(sim.sessions):
                session.writer.transport.abort()
            await board.switch(3, False)  # on a new connection
            assert not (await board.wait_for_state(3, False, 1.0)).channels[2].on

    run(test)


def test_no_board_is_a_clear_error_within_the_bounds() -> None:
    with socket.socket() as probe:  # a port that nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]

    async def test() -> None:
        with pytest.raises(RacError, match="cannot connect to the board") as caught:
            async with BoardClient(BoardAddress("127.0.0.1", port), FAST):
                pass
        assert codes(caught) == ["RAC090"]

    asyncio.run(asyncio.wait_for(test(), 10))


@pytest.mark.parametrize(
    ("text", "expected"),
    [("127.0.0.1:7000", BoardAddress("127.0.0.1", 7000)), ("[::1]:80", BoardAddress("::1", 80))],
)
def test_board_addresses(text: str, expected: BoardAddress) -> None:
    assert parse_address(text) == expected


@pytest.mark.parametrize("text", ["localhost", "host:0", "host:70000", ":80", "a:b"])
def test_bad_board_addresses(text: str) -> None:
    with pytest.raises(RacError, match="not a board address"):
        parse_address(text)


def test_targets_resolve_by_device_or_channel_with_did_you_mean() -> None:
    assert resolve_target("hokuyo", TEDUSAR) == 2
    assert resolve_target("7", TEDUSAR, 10) == 7
    with pytest.raises(RacError) as caught:
        resolve_target("jagaur", TEDUSAR)
    assert caught.value.diagnostics[0].hint == "did you mean 'jaguar'?"
    with pytest.raises(RacError, match="channel 11 is not on the board"):
        resolve_target("11", TEDUSAR, 10)


def test_plan_power_cycles_through_the_board_and_renders_node_steps() -> None:
    plan = [
        ("shutdown", "jaguar"),
        ("power_up", "jaguar"),
        ("stop_node", "jaguar_node"),
        ("start_node", "jaguar_node"),
    ]

    async def test(sim: BoardSimulator, address: BoardAddress) -> None:
        sim.state.trip(1)
        ros2 = suggested_commands("2")
        reports = await execute_plan(plan, TEDUSAR, address, settings=FAST, suggest=ros2)
        assert [r.action for r in reports] == [a for a, _ in plan]
        assert reports[0].outcome.startswith("channel 1 (jaguar) off")
        assert reports[1].outcome.startswith("channel 1 (jaguar) on")
        assert reports[2].outcome == "run yourself: pkill -INT -f '__node:=jaguar_node'"
        assert reports[3].outcome == "run yourself: ros2 run <package> jaguar_node"
        assert [r.executed for r in reports] == [True, True, False, False]
        assert sim.state.channels[0].on

    run(test)


def test_suggested_node_commands_follow_the_ros_in_use(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ROS_VERSION", "2")
    assert suggested_commands().render("start_node", "n") == "ros2 run <package> n"
    monkeypatch.setenv("ROS_VERSION", "1")
    assert suggested_commands().render("stop_node", "n") == "rosnode kill /n"
    assert suggested_commands().render("start_node", "n") == "rosrun <package> n"
    monkeypatch.delenv("ROS_VERSION")
    assert suggested_commands().render("stop_node", "n") == "rosnode kill /n"
    monkeypatch.setenv("ROS_VERSION", "1")
    assert suggested_commands("2").render("stop_node", "n") == "pkill -INT -f '__node:=n'"


def test_plan_runs_node_command_templates_and_fails_on_a_failing_one() -> None:
    plan = [("stop_node", "n1"), ("start_node", "n1")]
    ok = NodeCommands(start="true {node}", stop="true {node}")
    failing = parse_node_commands(["start=false {node}", "stop=true"])

    async def test(sim: BoardSimulator, address: BoardAddress) -> None:
        reports = await execute_plan(plan, TEDUSAR, address, node_commands=ok)
        assert [r.outcome for r in reports] == ["ran: true n1", "ran: true n1"]
        with pytest.raises(RacError, match="step 2 of 2, start_node") as caught:
            await execute_plan(plan, TEDUSAR, address, node_commands=failing)
        assert codes(caught) == ["RAC096"]

    run(test)


def test_plan_failures_name_the_step() -> None:
    async def test(sim: BoardSimulator, address: BoardAddress) -> None:
        sim.state.inject(2, Fault.JAMMED)
        sim.state.trip(2)
        with pytest.raises(RacError, match=r"step 1 of 1, power_up\(hokuyo\): board") as caught:
            await execute_plan(
                [("power_up", "hokuyo")], TEDUSAR, address, settings=FAST, confirm_within_s=0.3
            )
        assert codes(caught) == ["RAC093"]
        with pytest.raises(RacError, match="'kinect', which is on no board channel"):
            await execute_plan([("power_up", "kinect")], TEDUSAR, address, settings=FAST)
        with pytest.raises(RacError, match="no executor for plan action 'reboot'"):
            await execute_plan([("reboot", "jaguar")], TEDUSAR, address, settings=FAST)

    run(test)


@pytest.mark.parametrize(
    "specs",
    [
        ["start=x"],
        ["start=x", "stop"],
        ["go=x", "stop=y"],
        ["start=echo {nod}", "stop=true"],  # an unknown placeholder
        ["start=echo {0}", "stop=true"],
        ["start=true", "stop=echo 'unbalanced {node}"],  # an open quote
    ],
)
def test_bad_node_command_templates(specs: list[str]) -> None:
    with pytest.raises(RacError) as caught:
        parse_node_commands(specs)
    assert codes(caught) == ["RAC095"]


def test_a_connect_that_times_out_says_so() -> None:
    async def test(sim: BoardSimulator, address: BoardAddress) -> None:
        instant = ClientSettings(timeout_s=0.0, reconnects=0)
        with pytest.raises(RacError) as caught:
            async with BoardClient(address, instant):
                pass
        assert codes(caught) == ["RAC090"]
        assert caught.value.diagnostics[0].message.endswith(": timed out")

    run(test)
