"""``racc repair`` and ``racc scenario`` end to end, on every example model (models/*.ram).

Goldens live in tests/golden/repair/; ``pytest --update-goldens`` rewrites them.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
from test_repair_helpers import (
    GOLDEN,
    MODELS,
    SECTION_8_4,
    TEDUSAR,
    assert_drivers_after_devices,
    assert_valid,
    plan_text,
)

from rac.cli import main
from rac.load.theory import load_theory
from rac.repair import Kind, ScenarioResult, repair_system, run_scenario

Golden = Callable[[Path, str], None]

TINY = """\
robot tiny
hardware cam
hardware arm switchable channel 1
topic /img : sensor_msgs/Image { data } @ 10 Hz
topic /arm_state : std_msgs/Float64 { data } @ 10 Hz
node cam_node drives cam {
  publishes /img
  reports cam
}
node arm_node drives arm {
  subscribes /img
  publishes /arm_state
}
"""


def racc(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def obs_args(literals: tuple[str, ...]) -> list[str]:
    return [arg for lit in literals for arg in ("--obs", lit)]


@pytest.mark.parametrize("model", MODELS, ids=lambda p: p.stem)
def test_power_up_starts_everything_drivers_after_devices(model: Path, golden: Golden) -> None:
    theory = load_theory(str(model))
    result = run_scenario(theory, model.stem, "power-up")
    system = repair_system(theory)
    plan = result.repair.plan
    assert result.repair.prepared.bad == tuple(
        sorted(system.of_kind(Kind.NODE) + system.of_kind(Kind.DEVICE))
    )
    assert sorted(s[1] for s in plan if s[0] == "start_node") == sorted(system.of_kind(Kind.NODE))
    assert sorted(s[1] for s in plan if s[0] == "power_up") == sorted(system.of_kind(Kind.DEVICE))
    assert len(plan) == len(system.of_kind(Kind.NODE)) + len(system.of_kind(Kind.DEVICE))
    assert_drivers_after_devices(result.repair)
    assert_valid(result.repair)
    assert all(entry["good"] for entry in result.to_json()["state"].values())
    golden(GOLDEN / f"{model.stem}.power_up.problem.pddl", result.repair.prepared.problem_text)
    golden(GOLDEN / f"{model.stem}.power_up.plan.txt", plan_text(plan))


def _shutdown(model: Path) -> ScenarioResult | None:
    theory = load_theory(str(model))
    if not repair_system(theory).of_kind(Kind.DEVICE):
        return None
    return run_scenario(theory, model.stem, "device-shutdown")


@pytest.mark.parametrize("model", MODELS, ids=lambda p: p.stem)
def test_device_shutdown_restores_device_then_restarts_driver(
    model: Path, golden: Golden, capsys: pytest.CaptureFixture[str]
) -> None:
    result = _shutdown(model)
    if result is None:  # no switchable device (pioneer): nothing to shut down by default
        code, _, err = racc(capsys, "scenario", str(model), "device-shutdown")
        assert code == 1 and "RAC076" in err and "--device" in err
        return
    device = result.scenario.device
    assert device is not None
    system = result.repair.prepared.problem.system
    assert result.repair.prepared.bad == (device,)
    plan = result.repair.plan
    assert plan[0] == ("power_up", device)  # it is off already: no shutdown
    for driver in system.drivers_of(device):
        assert plan.index(("stop_node", driver)) < plan.index(("start_node", driver))
    assert len(plan) == 1 + 2 * len(system.drivers_of(device))
    assert_valid(result.repair)
    golden(
        GOLDEN / f"{model.stem}.device_shutdown.problem.pddl", result.repair.prepared.problem_text
    )
    golden(GOLDEN / f"{model.stem}.device_shutdown.plan.txt", plan_text(plan))


def test_scenario_command_prints_diagnosis_plan_and_state(
    capsys: pytest.CaptureFixture[str], golden: Golden
) -> None:
    code, out, _ = racc(capsys, "scenario", str(TEDUSAR), "power-up", "--validate")
    assert code == 0
    assert out.count("start_node(") == 9 and out.count("power_up(") == 3
    assert "state after the plan:" in out and " bad\n" not in out
    golden(GOLDEN / "tedusar.power_up.out.txt", out)


def test_scenario_json(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = racc(
        capsys, "scenario", str(TEDUSAR), "device-shutdown", "--device", "hokuyo", "--json"
    )
    doc = json.loads(out)
    assert code == 0 and doc["scenario"] == "device-shutdown" and doc["device"] == "hokuyo"
    assert doc["diagnosis"]["bad"] == ["hokuyo"] and doc["planner"] == "fast-downward"
    assert doc["plan"][0] == ["power_up", "hokuyo"]
    assert "not_on(hokuyo)" in doc["observations"] and "running(hokuyo_node)" in doc["observations"]
    assert doc["state"]["hokuyo"] == {"kind": "device", "on": True, "good": True}


def test_repair_command_section_8_4(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    problem = tmp_path / "problem.pddl"
    argv = ["repair", str(TEDUSAR), *obs_args(SECTION_8_4), "--validate"]
    code, out, _ = racc(capsys, *argv, "--problem-out", str(problem))
    assert code == 0
    steps = [line for line in out.splitlines() if line[:1].isdigit()]
    assert steps == [
        "1. shutdown(jaguar)",
        "2. power_up(jaguar)",
        "3. stop_node(jaguar_node)",
        "4. start_node(jaguar_node)",
    ]
    golden_problem = (GOLDEN / "section_8_4.problem.pddl").read_text(encoding="utf-8")
    assert problem.read_text(encoding="utf-8") == golden_problem


def test_repair_json_is_contract_7(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = racc(capsys, "repair", str(TEDUSAR), *obs_args(SECTION_8_4), "--json")
    doc = json.loads(out)
    assert code == 0 and list(doc) == ["diagnosis", "plan", "planner"]
    assert doc["diagnosis"]["bad"] == ["jaguar", "jaguar_node"]
    assert sorted(doc["diagnosis"]["bad"] + doc["diagnosis"]["good"]) == sorted(
        load_theory(str(TEDUSAR)).components
    )
    assert doc["plan"] == [
        ["shutdown", "jaguar"],
        ["power_up", "jaguar"],
        ["stop_node", "jaguar_node"],
        ["start_node", "jaguar_node"],
    ]
    assert doc["planner"] == "fast-downward"


def test_repair_with_nothing_wrong(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = racc(capsys, "repair", str(TEDUSAR), "--obs", "ok(pose)", "--json")
    assert code == 0 and json.loads(out)["plan"] == []
    code, out, _ = racc(capsys, "repair", str(TEDUSAR), "--obs", "ok(pose)")
    assert code == 0 and "no repair needed" in out


@pytest.mark.parametrize("strategy", ["minimal", "first"])
def test_impossible_repair_names_the_component(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], strategy: str
) -> None:
    model = tmp_path / "tiny.ram"
    model.write_text(TINY, encoding="utf-8")
    observed = ("running(cam_node)", "ok(img)", "not ok(cam)")
    argv = ["repair", str(model), *obs_args(observed), "--strategy", strategy]
    code, out, err = racc(capsys, *argv)
    if strategy == "minimal":
        # {cam} and {cam_node} explain the fault alike; only the node can be repaired, so
        # the minimal strategy restarts it and names the camera as the other suspect.
        assert code == 0 and "start_node(cam_node)" in out
        assert "no action can repair it: {cam}" in out
        return
    assert code == 3 and out == ""
    assert "RAC071" in err and "make cam good" in err and "not switchable" in err


def test_impossible_scenario_names_the_component(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = tmp_path / "tiny.ram"
    model.write_text(TINY, encoding="utf-8")
    code, _, err = racc(capsys, "scenario", str(model), "device-shutdown", "--device", "cam")
    assert code == 3 and "make cam good" in err
    code, _, err = racc(capsys, "scenario", str(model), "device-shutdown", "--device", "camm")
    assert code == 1 and "did you mean 'cam'?" in err


def test_model_yaml_without_a_diagnosis(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = tmp_path / "model.yaml"
    model.write_text(
        "ab: AB\nnab: NAB\nneg_prefix: not_\nprops: [ok(x), ok(y)]\n"
        "rules:\n- NAB(a) -> ok(x)\n- ok(x), ok(y) -> false\n",
        encoding="utf-8",
    )
    code, _, err = racc(capsys, "repair", str(model), "--obs", "ok(x)", "--obs", "ok(y)")
    assert code == 3 and "RAC070" in err


def test_model_yaml_repair(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = tmp_path / "robot.yaml"
    model.write_text(
        "ab: AB\nnab: NAB\nneg_prefix: not_\nprops: [on(cam), running(cam_node), ok(img)]\n"
        "rules:\n- NAB(cam) -> on(cam)\n- NAB(cam_node) -> running(cam_node)\n"
        "- NAB(cam_node), NAB(cam) -> ok(img)\n",
        encoding="utf-8",
    )
    argv = ["repair", str(model), "--obs", "not on(cam)", "--obs", "running(cam_node)", "--json"]
    code, out, _ = racc(capsys, *argv)
    assert code == 0
    assert json.loads(out)["plan"] == [
        ["power_up", "cam"],
        ["stop_node", "cam_node"],
        ["start_node", "cam_node"],
    ]


def test_validate_without_unified_planning(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "unified_planning.io", None)
    argv = ["repair", str(TEDUSAR), *obs_args(SECTION_8_4), "--validate"]
    code, out, err = racc(capsys, *argv)
    assert code == 3 and out == "" and "unified-planning is not installed" in err


def test_missing_planner_exits_3(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setenv("RACC_FAST_DOWNWARD", str(tmp_path / "nowhere.py"))
    code, _, err = racc(capsys, "scenario", str(TEDUSAR), "power-up")
    assert code == 3 and "RAC072" in err and "pip install up-fast-downward" in err


@pytest.mark.parametrize("value", ["0", "-1", "soon", "nan", "inf", "1e300"])
def test_bad_planner_timeout_is_a_usage_error(value: str) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["repair", str(TEDUSAR), "--obs", "ok(pose)", "--planner-timeout", value])
    assert exit_info.value.code == 2


def test_unknown_observation_is_an_input_error(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = racc(capsys, "repair", str(TEDUSAR), "--obs", "ok(poze)")
    assert code == 1 and "RAC040" in err


def test_scenario_on_a_model_yaml(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Kinds inferred from the clauses: the power-up plan is the .ram's, driver order included."""
    from rac.pipeline import compile_model
    from rac.targets import EmitOptions
    from rac.targets.model_yaml import emit_model_yaml

    theory = load_theory(str(TEDUSAR))
    assert theory.model is not None
    (tmp_path / "tedusar").mkdir()
    path = tmp_path / "tedusar" / "model.yaml"
    path.write_text(emit_model_yaml(compile_model(theory.model), EmitOptions()), encoding="utf-8")
    code, out, _ = racc(capsys, "scenario", str(path), "power-up", "--json")
    doc = json.loads(out)
    assert code == 0 and doc["diagnosis"]["bad"] == list(theory.components)
    plan = [tuple(step) for step in doc["plan"]]
    assert plan.index(("power_up", "jaguar")) < plan.index(("start_node", "jaguar_node"))
    assert len(plan) == 12


def test_scenario_on_a_model_yaml_without_props(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Without props every rule head is observed (as racc simulate does), not nothing at all."""
    model = tmp_path / "robot.yaml"
    model.write_text(
        "rules:\n- NAB(cam) -> on(cam)\n- NAB(cam_node) -> running(cam_node)\n"
        "- NAB(cam_node), NAB(cam) -> ok(img)\n",
        encoding="utf-8",
    )
    code, out, _ = racc(capsys, "scenario", str(model), "power-up", "--json")
    doc = json.loads(out)
    assert code == 0 and doc["diagnosis"]["bad"] == ["cam", "cam_node"]
    assert doc["plan"] == [["power_up", "cam"], ["start_node", "cam_node"]]


def test_device_with_power_up_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = racc(capsys, "scenario", str(TEDUSAR), "power-up", "--device", "hokuyo")
    assert code == 2 and out == "" and "--device" in err
