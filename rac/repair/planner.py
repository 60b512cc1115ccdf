"""callPlanner (Algorithm 11): Fast Downward through its driver script.

The ``up-fast-downward`` wheel ships the driver and binaries; we run the
driver with the current Python in a temporary directory (it writes
``output.sas`` and ``sas_plan`` into its working directory), under a
wall-clock limit, and read ``sas_plan`` back.
"""

from __future__ import annotations

import importlib.util
import math
import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from rac.repair.errors import NoRepairPlan

PLANNER = "fast-downward"
# Lazy greedy best-first search on the FF heuristic with preferred operators: repair problems
# are easy, and unlike lama-first it builds no landmark graph, which costs seconds at 1,000
# components (bench/repair.py).
DEFAULT_SEARCH = "let(h, ff(), lazy_greedy([h], preferred=[h]))"
DEFAULT_TIMEOUT_S = 60.0

# Fast Downward's exit codes (driver/returncodes.py of the bundled version).  A component
# killed by SIGXCPU (its CPU limit ran out before it could catch it) makes the driver exit
# with 256 - SIGXCPU.
_UNSOLVABLE = {10, 11}
_INCOMPLETE = {12, 13}
_OUT_OF_TIME = {21, 23, 24, 256 - signal.SIGXCPU, -signal.SIGXCPU}
_OUT_OF_MEMORY = {20, 22}

Step = tuple[str, ...]  # ("shutdown", "jaguar"): action name, then its arguments


@dataclass(frozen=True, slots=True)
class PlannerRun:
    plan: tuple[Step, ...]
    seconds: float


def driver_path() -> Path | None:
    """The bundled ``fast-downward.py``, or None when the wheel is not installed."""
    override = os.environ.get("RACC_FAST_DOWNWARD")  # tests and unusual installs
    if override:
        return Path(override) if Path(override).is_file() else None
    # find_spec locates the package without importing it: its __init__ imports
    # unified-planning, which costs seconds we do not need.
    spec = importlib.util.find_spec("up_fast_downward")
    for folder in (spec.submodule_search_locations or []) if spec else []:
        path = Path(folder) / "downward" / "fast-downward.py"
        if path.is_file():
            return path
    return None


def parse_plan(text: str) -> tuple[Step, ...]:
    """``sas_plan`` lines ``(shutdown jaguar)``; ``;`` starts a comment (the cost line)."""
    steps: list[Step] = []
    for raw in text.splitlines():
        line = raw.split(";", 1)[0].strip()
        if not line:
            continue
        if not (line.startswith("(") and line.endswith(")")):
            raise ValueError(f"not a plan step: {raw!r}")
        words = line[1:-1].split()
        if not words:
            raise ValueError(f"empty plan step: {raw!r}")
        steps.append(tuple(w.lower() for w in words))
    return tuple(steps)


def _tail(text: str, lines: int = 8) -> str:
    return "\n".join(text.strip().splitlines()[-lines:])


def run_planner(
    domain: str, problem: str, timeout_s: float = DEFAULT_TIMEOUT_S, search: str = DEFAULT_SEARCH
) -> PlannerRun:
    """Solve ``problem`` in ``domain`` (PDDL texts); raise NoRepairPlan when there is no plan."""
    driver = driver_path()
    if driver is None:
        override = os.environ.get("RACC_FAST_DOWNWARD")
        if override:  # installing the wheel would not help: the variable wins
            raise NoRepairPlan(
                "RAC072",
                f"the planner Fast Downward was not found: RACC_FAST_DOWNWARD={override} "
                "is no file",
                hint="point RACC_FAST_DOWNWARD at a fast-downward.py, or unset it and use "
                "the wheel: pip install up-fast-downward",
            )
        raise NoRepairPlan(
            "RAC072",
            "the planner Fast Downward was not found",
            hint="install it with: pip install up-fast-downward",
        )
    with tempfile.TemporaryDirectory(prefix="racc-plan-") as tmp:
        work = Path(tmp)
        (work / "domain.pddl").write_text(domain, encoding="utf-8")
        (work / "problem.pddl").write_text(problem, encoding="utf-8")
        # FD's --overall-time-limit counts CPU seconds, its own driver's start-up included,
        # and hands each component the remainder rounded down: a limit of 1 s left the
        # translator 0 s.  So FD gets a second more than asked, and the wall clock below
        # holds the planner to ``timeout_s``.
        limit = math.ceil(timeout_s) + 1
        cmd = [
            sys.executable,
            str(driver),
            "--plan-file",
            "sas_plan",
            "--overall-time-limit",
            f"{limit}s",
            "domain.pddl",
            "problem.pddl",
            "--search",
            search,
        ]
        start = time.monotonic()
        finished = run_bounded(cmd, work, timeout_s)
        if finished is None:
            raise _timed_out(timeout_s)
        seconds = time.monotonic() - start
        code, output = finished
        plan_file = work / "sas_plan"
        if code == 0 and plan_file.is_file():
            try:
                plan = parse_plan(plan_file.read_text(encoding="utf-8"))
            except ValueError as err:
                raise NoRepairPlan("RAC073", f"cannot read the planner's plan: {err}") from None
            return PlannerRun(plan, seconds)
    raise _failure(code, output, timeout_s)


def run_bounded(cmd: list[str], cwd: Path, timeout_s: float) -> tuple[int, str] | None:
    """Run ``cmd`` in its own session: its exit code and output (stderr included), or None
    when it ran out of time.  The whole session is killed then, so a planner's driver does
    not leave the search it started running."""
    with subprocess.Popen(
        cmd,
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    ) as proc:
        try:
            output, _ = proc.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
            return None
    return proc.returncode, output


def _timed_out(timeout_s: float) -> NoRepairPlan:
    return NoRepairPlan(
        "RAC074",
        f"the planner found no plan within {timeout_s:g} s",
        hint="allow more time with --planner-timeout SECONDS",
    )


def _failure(code: int, output: str, timeout_s: float) -> NoRepairPlan:
    if code in _UNSOLVABLE or code in _INCOMPLETE:
        return NoRepairPlan(
            "RAC075",
            "the repair problem is unsolvable: no sequence of repair actions makes "
            "every component good",
        )
    if code in _OUT_OF_TIME:
        return _timed_out(timeout_s)
    if code in _OUT_OF_MEMORY:
        return NoRepairPlan("RAC073", "the planner ran out of memory")
    detail = _tail(output)
    return NoRepairPlan(
        "RAC073",
        f"the planner failed (exit code {code})" + (f":\n{detail}" if detail else ""),
    )
