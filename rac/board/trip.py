"""The device-shutdown scenario driven end to end against a board, over its TCP protocol
(the planning in between is :mod:`rac.repair`'s; the data is :mod:`rac.board.scenario`'s)."""

from __future__ import annotations

import asyncio
import time

from rac.board.channels import ChannelMap, channel_map, check_fits, hobs_literals
from rac.board.client import (
    DEFAULT_SETTINGS,
    BoardAddress,
    BoardClient,
    ClientSettings,
    board_error,
)
from rac.board.control import send_control
from rac.board.execute import NodeCommands, execute_plan
from rac.board.scenario import CONFIRM_WITHIN_S, BoardScenario, board_observations, device_channel
from rac.diagnosis import Theory
from rac.errors import Diagnostic, RacError
from rac.repair.engine import prepare, solve
from rac.repair.planner import DEFAULT_TIMEOUT_S
from rac.repair.scenario import make_scenario


async def _observe(
    client: BoardClient, channels: ChannelMap, channel: int, on: bool
) -> tuple[str, ...]:
    msr = await client.wait_for_state(channel, on, CONFIRM_WITHIN_S)
    return hobs_literals(channels, msr)


async def device_shutdown_on_board(
    theory: Theory,
    robot: str,
    address: BoardAddress,
    *,
    device: str | None = None,
    control: BoardAddress | None = None,
    node_commands: NodeCommands | None = None,
    suggest: NodeCommands | None = None,
    settings: ClientSettings = DEFAULT_SETTINGS,
    planner_timeout_s: float = DEFAULT_TIMEOUT_S,
) -> BoardScenario:
    """Run the scenario; RacError when a step fails, NoRepairPlan when no plan exists."""
    if theory.model is None:
        raise RacError(
            [
                Diagnostic(
                    "RAC092", "the board scenario needs a .ram/.json model (it holds the channels)"
                )
            ]
        )
    start = time.monotonic()
    channels = channel_map(theory.model)
    scenario = make_scenario(theory, "device-shutdown", device)
    assert scenario.device is not None
    name, number = device_channel(scenario.device, channels)
    async with BoardClient(address, settings) as client:
        check_fits(channels, client.channel_count)
        before = hobs_literals(channels, await client.measure())
        if control is not None:
            try:
                reply = await send_control(control.host, control.port, f"trip {number}")
            except (OSError, TimeoutError, asyncio.TimeoutError) as err:
                raise board_error(
                    "RAC090",
                    f"cannot reach the control port {control}: {str(err) or 'timed out'}",
                    hint="is it `racc board-sim`'s control port (its second line of output)?",
                ) from None
            if not reply.startswith("ok"):
                raise board_error("RAC091", f"the control port refused the trip: {reply}")
            tripped_by = "control port"
        else:  # a real board cannot be told to fail: cut the power instead
            await client.switch(number, False)
            tripped_by = "SWT off"
        tripped = await _observe(client, channels, number, False)
    theta = board_observations(theory, scenario.faulty, tripped)
    planning_start = time.monotonic()
    repair = await asyncio.to_thread(
        lambda: solve(prepare(theory, theta, robot), planner_timeout_s)
    )
    planning_seconds = time.monotonic() - planning_start
    plan = [(step[0], step[1]) for step in repair.plan]
    steps = await execute_plan(
        plan, channels, address, node_commands=node_commands, suggest=suggest, settings=settings
    )
    async with BoardClient(address, settings) as client:
        after = await _observe(client, channels, number, True)
    return BoardScenario(
        device=name,
        channel=number,
        tripped_by=tripped_by,
        before=before,
        tripped=tripped,
        observations=tuple(str(lit) for lit in theta),
        repair=repair,
        steps=steps,
        after=after,
        seconds=time.monotonic() - start,
        planning_seconds=planning_seconds,
    )
