"""The device-shutdown scenario (§10.1.1.2, §8.5) end to end against a board.

Trip a device on the board, observe ``not_on`` from its MSR (HObs, §5.2.6), diagnose, plan,
execute the plan's hardware steps through the board and observe ``on`` again.  The board
gives the hardware observations; the software observers' literals are what they would
report with the device off (``rac.repair.scenario.observations``), since no robot runs here.
"""

from __future__ import annotations

import asyncio
import time
from dataclasses import dataclass
from typing import Any

from rac.board.channels import ChannelMap, channel_map, check_fits, hobs_literals
from rac.board.client import (
    DEFAULT_SETTINGS,
    BoardAddress,
    BoardClient,
    ClientSettings,
    board_error,
)
from rac.board.control import send_control
from rac.board.execute import NodeCommands, StepReport, execute_plan, reports_json
from rac.diagnosis import Literal, Theory
from rac.errors import Diagnostic, RacError
from rac.logic import mangle
from rac.repair.engine import RepairResult, prepare, solve
from rac.repair.planner import DEFAULT_TIMEOUT_S
from rac.repair.scenario import make_scenario, observations

CONFIRM_WITHIN_S = 2.0


@dataclass(frozen=True, slots=True)
class BoardScenario:
    device: str
    channel: int
    tripped_by: str  # "control port" or "SWT off"
    before: tuple[str, ...]  # HObs literals before the trip
    tripped: tuple[str, ...]  # HObs literals after it
    observations: tuple[str, ...]  # Θ given to the diagnosis
    repair: RepairResult
    steps: tuple[StepReport, ...]
    after: tuple[str, ...]  # HObs literals after the repair
    seconds: float  # end to end
    planning_seconds: float  # diagnosis and planner, wall clock (the planner is a subprocess)

    def to_json(self) -> dict[str, Any]:
        return {
            "scenario": "device-shutdown",
            "device": self.device,
            "channel": self.channel,
            "tripped_by": self.tripped_by,
            "board_before": list(self.before),
            "board_tripped": list(self.tripped),
            "observations": list(self.observations),
            **self.repair.to_json(),
            **reports_json(self.steps),
            "board_after": list(self.after),
            "seconds": round(self.seconds, 3),
            "planning_seconds": round(self.planning_seconds, 3),
        }


def _device_channel(device: str, channels: ChannelMap) -> tuple[str, int]:
    for number, name in channels.devices:
        if mangle(name) == device:
            return name, number
    raise board_error("RAC092", f"'{device}' is on no board channel of the model")


def board_observations(
    theory: Theory, faulty: tuple[str, ...], board: tuple[str, ...]
) -> tuple[Literal, ...]:
    """Θ: the board's ``on``/``not_on`` literals replace the predicted ones."""
    measured = {
        text.removeprefix(theory.neg_prefix): not text.startswith(theory.neg_prefix)
        for text in board
    }
    return tuple(
        Literal(lit.atom, measured.get(str(lit.atom), lit.positive), lit.neg_prefix)
        for lit in observations(theory, faulty)
    )


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
    name, number = _device_channel(scenario.device, channels)
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


def render(run: BoardScenario) -> str:
    """The human-readable account ``racc scenario --board`` prints."""
    lines = [
        f"device-shutdown on the board: {run.device} (channel {run.channel})",
        f"  board before:  {' '.join(run.before)}",
        f"  tripped by {run.tripped_by}: {' '.join(run.tripped)}",
        f"  diagnosis: bad {', '.join(run.repair.prepared.bad) or '-'}",
        "  plan: " + (", ".join(f"{s[0]}({', '.join(s[1:])})" for s in run.repair.plan) or "-"),
    ]
    lines += [f"  {'executed' if step.executed else 'to run'} {step}" for step in run.steps]
    lines += [
        f"  board after:   {' '.join(run.after)}",
        f"  took {run.seconds:.2f} s ({run.planning_seconds:.2f} s diagnosing and planning)",
    ]
    return "\n".join(lines)
