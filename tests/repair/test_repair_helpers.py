"""Shared by the repair tests (no tests here): the dissertation's observation sets, plan checks."""

from __future__ import annotations

from pathlib import Path

from rac.diagnosis import Literal, Theory, collect, parse_literal
from rac.load.theory import load_theory
from rac.repair import Kind, RepairResult, Step
from rac.repair.validate import validate_plan

ROOT = Path(__file__).resolve().parents[2]
MODELS = sorted((ROOT / "models").glob("*.ram"))
TEDUSAR = ROOT / "models" / "tedusar.ram"
GOLDEN = Path(__file__).resolve().parents[1] / "golden" / "repair"

# §7.1.2.1's Θ with the full names, plus ok(pose): the dissertation's Δ = {hm} takes /pose
# for granted (without it, jaguar and jaguar_node would explain ¬ok(map) as well).
EXAMPLE_7_3 = (
    "running(jaguar_node)",
    "running(hokuyo_node)",
    "running(imu_node)",
    "running(laser_alignment_node)",
    "running(jaguar_teleop_node)",
    "running(hector_mapping)",
    "running(laser_alignment_control)",
    "running(joy_node)",
    "running(rviz)",
    "ok(cmd_vel)",
    "ok(scan)",
    "ok(imu_data)",
    "ok(joy)",
    "not_ok(map)",
    "ok(la_servo1_moving)",
    "ok(la_servo2_moving)",
    "on(jaguar)",
    "on(hokuyo)",
    "on(laser_alignment)",
    "ok(pose)",
)
SECTION_8_4 = ("on(jaguar)", "running(jaguar_node)", "not ok(pose)")


def theta(theory: Theory, texts: tuple[str, ...]) -> tuple[Literal, ...]:
    return collect(parse_literal(t, theory) for t in texts)


def tedusar() -> Theory:
    return load_theory(str(TEDUSAR))


def plan_text(plan: tuple[Step, ...]) -> str:
    return "".join(f"{i}. {s[0]}({', '.join(s[1:])})\n" for i, s in enumerate(plan, 1))


def assert_valid(result: RepairResult) -> None:
    """unified-planning's validator accepts the plan for the domain and problem text."""
    prepared = result.prepared
    validate_plan(prepared.domain_text, prepared.problem_text, prepared.problem, result.plan)


def assert_drivers_after_devices(result: RepairResult) -> None:
    """Every driver's last start comes after its device's last power-up."""
    system = result.prepared.problem.system
    last = {step: i for i, step in enumerate(result.plan)}
    for node, device in system.drives:
        if ("start_node", node) in last and ("power_up", device) in last:
            assert last[("power_up", device)] < last[("start_node", node)], (node, device)
    assert all(system.kind(s[1]) is not Kind.HARDWARE for s in result.plan)
