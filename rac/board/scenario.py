"""The device-shutdown scenario (§10.1.1.2, §8.5) on a board: its data and its observations.

:mod:`rac.board.trip` drives it against a board: trip a device, observe ``not_on`` from its
MSR (HObs, §5.2.6), diagnose, plan, execute the plan's hardware steps through the board and
observe ``on`` again.  The board gives the hardware observations; the software observers'
literals are what they would report with the device off (``rac.repair.scenario.observations``),
since no robot runs here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from rac.board.channels import ChannelMap
from rac.board.client import (
    board_error,
)
from rac.board.execute import StepReport, reports_json
from rac.diagnosis import Literal, Theory
from rac.logic import mangle
from rac.repair.engine import RepairResult
from rac.repair.scenario import observations

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


def device_channel(device: str, channels: ChannelMap) -> tuple[str, int]:
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
