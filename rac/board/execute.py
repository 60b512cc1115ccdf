"""Carry out a repair plan (the ``plan`` of ``racc repair --json``) through the board.

``power_up``/``shutdown`` become SWT commands, and each step waits for the MSR that shows the
new state (the dissertation's repair engine did not wait for effects, errata chapter 7).
Node steps are rendered as the commands a user would run, or run when templates are given.
"""

from __future__ import annotations

import asyncio
import os
import shlex
import subprocess
from collections.abc import Sequence
from dataclasses import dataclass, replace

from rac.board.channels import ChannelMap, check_fits
from rac.board.client import (
    DEFAULT_SETTINGS,
    BoardAddress,
    BoardClient,
    ClientSettings,
    board_error,
)
from rac.errors import Diagnostic, RacError
from rac.logic import mangle

HARDWARE_ACTIONS = {"power_up": True, "shutdown": False}
NODE_ACTIONS = ("start_node", "stop_node")
CONFIRM_WITHIN_S = 2.0
NODE_COMMAND_TIMEOUT_S = 60.0


@dataclass(frozen=True, slots=True)
class NodeCommands:
    """Shell command templates for node steps; ``{node}`` is the node's name."""

    start: str
    stop: str

    def render(self, action: str, node: str) -> str:
        template = self.start if action == "start_node" else self.stop
        return template.format(node=node)


ROS1_COMMANDS = NodeCommands(start="rosrun <package> {node}", stop="rosnode kill /{node}")
ROS2_COMMANDS = NodeCommands(
    start="ros2 run <package> {node}", stop="pkill -INT -f '__node:={node}'"
)


def suggested_commands(ros: str | None = None) -> NodeCommands:
    """The node commands to suggest for ROS ``ros`` ("1" or "2"); by default the ROS in use
    as its setup script says (``ROS_VERSION``), ROS 1 when none is sourced."""
    version = ros if ros is not None else os.environ.get("ROS_VERSION", "1").strip()
    return ROS2_COMMANDS if version == "2" else ROS1_COMMANDS


def parse_node_commands(specs: Sequence[str]) -> NodeCommands:
    """From ``start=TEMPLATE`` and ``stop=TEMPLATE`` (both needed)."""
    found: dict[str, str] = {}
    for spec in specs:
        key, sep, template = spec.partition("=")
        if not sep or key not in ("start", "stop") or not template.strip():
            raise RacError(
                [
                    Diagnostic(
                        "RAC095",
                        f"bad --node-commands '{spec}'",
                        hint="give start=TEMPLATE and stop=TEMPLATE, {node} is the node",
                    )
                ]
            )
        found[key] = template
    missing = [k for k in ("start", "stop") if k not in found]
    if missing:
        raise RacError([Diagnostic("RAC095", f"--node-commands lacks {' and '.join(missing)}=…")])
    commands = NodeCommands(start=found["start"], stop=found["stop"])
    for action in NODE_ACTIONS:  # fail now, not after the plan's hardware steps have run
        template = commands.start if action == "start_node" else commands.stop
        try:
            shlex.split(commands.render(action, "node"))
        except (KeyError, IndexError, ValueError) as err:
            raise RacError(
                [
                    Diagnostic(
                        "RAC095",
                        f"bad --node-commands template '{template}': {err}",
                        hint="{node} is the only placeholder; write {{ and }} for braces, "
                        "and close every quote",
                    )
                ]
            ) from None
    return commands


@dataclass(frozen=True, slots=True)
class StepReport:
    action: str
    argument: str
    outcome: str  # what happened, or the command the user should run
    executed: bool = True  # False: only printed, for the user to run

    def __str__(self) -> str:
        return f"{self.action}({self.argument}): {self.outcome}"


def reports_json(reports: Sequence[StepReport]) -> dict[str, list[str]]:
    """The steps racc carried out, and those it only printed for the user to run."""
    return {
        "executed": [str(r) for r in reports if r.executed],
        "to_run": [str(r) for r in reports if not r.executed],
    }


def _device_for(argument: str, channels: ChannelMap) -> tuple[int, str]:
    """Plan arguments are mangled (and PDDL planners lower-case them)."""
    for number, device in channels.devices:
        if mangle(device).lower() == argument.lower():
            return number, device
    known = ", ".join(d for _, d in channels.devices) or "none"
    raise board_error(
        "RAC092", f"the plan switches '{argument}', which is on no board channel (known: {known})"
    )


def _run_node_command(command: str) -> str:
    try:
        done = subprocess.run(
            shlex.split(command), capture_output=True, timeout=NODE_COMMAND_TIMEOUT_S, check=False
        )
    except (OSError, subprocess.TimeoutExpired) as err:
        raise board_error("RAC096", f"node command failed: {command}: {err}") from None
    if done.returncode != 0:
        detail = done.stderr.decode(errors="replace").strip().splitlines()
        raise board_error(
            "RAC096",
            f"node command exited {done.returncode}: {command}",
            hint=detail[-1] if detail else None,
        )
    return f"ran: {command}"


async def _step(
    action: str,
    argument: str,
    channels: ChannelMap,
    client: BoardClient | None,
    node_commands: NodeCommands | None,
    suggest: NodeCommands,
    confirm_within_s: float,
) -> str:
    if action in HARDWARE_ACTIONS:
        assert client is not None
        number, device = _device_for(argument, channels)
        on = HARDWARE_ACTIONS[action]
        await client.switch(number, on)
        msr = await client.wait_for_state(number, on, confirm_within_s)
        reading = msr.channels[number - 1]
        return (
            f"channel {number} ({device}) {'on' if on else 'off'}, "
            f"{reading.current:.2f} A, {reading.voltage:.2f} V"
        )
    if node_commands is not None:
        return _run_node_command(node_commands.render(action, argument))
    return "run yourself: " + suggest.render(action, argument)


async def execute_plan(
    plan: Sequence[tuple[str, str]],
    channels: ChannelMap,
    address: BoardAddress | None,
    *,
    node_commands: NodeCommands | None = None,
    suggest: NodeCommands | None = None,
    settings: ClientSettings = DEFAULT_SETTINGS,
    confirm_within_s: float = CONFIRM_WITHIN_S,
) -> tuple[StepReport, ...]:
    """Run every step in order; the first failing step raises RacError (RAC09x).

    Without ``node_commands`` node steps are not run: their report names the command
    (from ``suggest``) that a user would run.
    """
    suggest = suggest if suggest is not None else suggested_commands()
    for action, _ in plan:
        if action not in HARDWARE_ACTIONS and action not in NODE_ACTIONS:
            raise board_error("RAC096", f"no executor for plan action '{action}'")
    reports: list[StepReport] = []
    needs_board = any(action in HARDWARE_ACTIONS for action, _ in plan)
    if needs_board and address is None:
        raise board_error("RAC090", "the plan has power_up/shutdown steps but no board is given")
    client = BoardClient(address, settings) if needs_board and address is not None else None
    try:
        if client is not None:
            await client.__aenter__()
            check_fits(channels, client.channel_count)
        for index, (action, argument) in enumerate(plan, start=1):
            try:
                outcome = await _step(
                    action, argument, channels, client, node_commands, suggest, confirm_within_s
                )
            except RacError as err:
                where = f"step {index} of {len(plan)}, {action}({argument}): "
                raise RacError(
                    [replace(d, message=where + d.message) for d in err.diagnostics]
                ) from None
            printed = action in NODE_ACTIONS and node_commands is None
            reports.append(StepReport(action, argument, outcome, executed=not printed))
    finally:
        if client is not None:
            await client.close()
    return tuple(reports)


def run_plan(
    plan: Sequence[tuple[str, str]],
    channels: ChannelMap,
    address: BoardAddress | None,
    *,
    node_commands: NodeCommands | None = None,
    suggest: NodeCommands | None = None,
    confirm_within_s: float = CONFIRM_WITHIN_S,
) -> tuple[StepReport, ...]:
    """``execute_plan`` for synchronous callers such as ``racc repair --execute``."""
    return asyncio.run(
        execute_plan(
            plan,
            channels,
            address,
            node_commands=node_commands,
            suggest=suggest,
            confirm_within_s=confirm_within_s,
        )
    )
