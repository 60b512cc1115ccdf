"""Repair engine: problem generation, diagnosis choice, planner, simulation (chapter 7).

Goldens live in tests/golden/repair/; ``pytest --update-goldens`` rewrites them.
Every plan is checked by unified-planning's validator and by rac.repair.simulate.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pddl import parse_domain, parse_problem
from test_repair_helpers import (
    EXAMPLE_7_3,
    GOLDEN,
    SECTION_8_4,
    assert_valid,
    plan_text,
    tedusar,
    theta,
)

from rac.diagnosis import Literal, Theory, diagnose
from rac.load.theory import load_theory
from rac.logic import Atom
from rac.repair import (
    InapplicableStep,
    Kind,
    NoRepairPlan,
    RepairProblem,
    RepairSystem,
    check_plan,
    choose_bad,
    make_problem,
    parse_plan,
    prepare,
    render_problem,
    repair_system,
    run_planner,
    simulate,
    solve,
    system_from_clauses,
)
from rac.repair.planner import _failure
from rac.repair.problem import pddl_names
from rac.repair.validate import validate_plan
from rac.targets import EmitOptions
from rac.targets.model_yaml import emit_model_yaml
from rac.targets.pddl_domain import render_repair_domain

Golden = Callable[[Path, str], None]


@pytest.fixture(scope="module")
def theory() -> Theory:
    return tedusar()


def test_domain_and_problem_parse_with_the_pddl_library(theory: Theory, tmp_path: Path) -> None:
    prepared = prepare(theory, theta(theory, SECTION_8_4), "tedusar")
    (tmp_path / "d.pddl").write_text(prepared.domain_text, encoding="utf-8")
    (tmp_path / "p.pddl").write_text(prepared.problem_text, encoding="utf-8")
    domain = parse_domain(tmp_path / "d.pddl")
    problem = parse_problem(tmp_path / "p.pddl")
    assert {a.name for a in domain.actions} == {"start_node", "stop_node", "power_up", "shutdown"}
    assert problem.domain_name == domain.name == "repair_tedusar"
    assert {o.name for o in problem.objects} == set(theory.components)


def test_example_7_3_restarts_the_running_faulty_mapper(theory: Theory, golden: Golden) -> None:
    observations = theta(theory, EXAMPLE_7_3)
    assert diagnose(theory, observations).diagnoses == (("hector_mapping",),)
    result = solve(prepare(theory, observations, "tedusar"))
    assert result.plan == (("stop_node", "hector_mapping"), ("start_node", "hector_mapping"))
    assert_valid(result)
    golden(GOLDEN / "example_7_3.problem.pddl", result.prepared.problem_text)
    golden(GOLDEN / "example_7_3.plan.txt", plan_text(result.plan))


def test_section_8_4_repairs_device_and_driver_in_one_plan(theory: Theory, golden: Golden) -> None:
    result = solve(prepare(theory, theta(theory, SECTION_8_4), "tedusar"))
    assert result.prepared.bad == ("jaguar", "jaguar_node")
    assert sorted(result.plan) == sorted(
        [
            ("shutdown", "jaguar"),
            ("power_up", "jaguar"),
            ("stop_node", "jaguar_node"),
            ("start_node", "jaguar_node"),
        ]
    )
    assert result.plan.index(("shutdown", "jaguar")) < result.plan.index(("power_up", "jaguar"))
    assert result.plan.index(("power_up", "jaguar")) < result.plan.index(
        ("start_node", "jaguar_node")
    )
    assert_valid(result)
    golden(GOLDEN / "section_8_4.problem.pddl", result.prepared.problem_text)
    golden(GOLDEN / "section_8_4.plan.txt", plan_text(result.plan))


def test_first_strategy_plans_for_the_first_diagnosis(theory: Theory, golden: Golden) -> None:
    result = solve(prepare(theory, theta(theory, SECTION_8_4), "tedusar", "first"))
    assert result.prepared.bad == ("jaguar",)
    # Power-cycling jaguar leaves its driver needing a restart: the plan does that too.
    assert ("start_node", "jaguar_node") in result.plan
    assert_valid(result)
    golden(GOLDEN / "section_8_4_first.plan.txt", plan_text(result.plan))


def test_consistent_observations_need_no_repair(theory: Theory) -> None:
    result = solve(prepare(theory, theta(theory, ("ok(pose)", "running(rviz)")), "tedusar"))
    assert result.plan == ()
    assert result.to_json() == {
        "diagnosis": {"bad": [], "good": list(theory.components)},
        "plan": [],
        "planner": "fast-downward",
    }


def test_choose_bad_strategies() -> None:
    diagnoses = (("a",), ("b",), ("c", "d"))
    assert choose_bad(diagnoses, "minimal") == ("a", "b")
    assert choose_bad(diagnoses, "first") == ("a",)
    assert choose_bad((), "minimal") == ()
    with pytest.raises(ValueError, match="unknown strategy"):
        choose_bad(diagnoses, "best")


def test_silent_components_are_in_their_normal_state(theory: Theory) -> None:
    system = repair_system(theory)
    observations = theta(theory, ("not running(rviz)", "not on(hokuyo)"))
    problem = make_problem("tedusar", system, observations, ("rviz", "hokuyo"))
    assert set(problem.running) == set(system.of_kind(Kind.NODE)) - {"rviz"}
    assert set(problem.on) == {"jaguar", "laser_alignment"}
    assert problem.good == tuple(c for c in theory.components if c not in ("hokuyo", "rviz"))
    text = render_problem(problem)
    assert "(running rviz)" not in text and "(on hokuyo)" not in text
    assert "(bad rviz)" in text and "(good jaguar)" in text
    assert "(drives hokuyo_node hokuyo)" in text


def test_problem_rejects_unknown_bad_components(theory: Theory) -> None:
    with pytest.raises(ValueError, match="imu"):
        make_problem("tedusar", repair_system(theory), (), ("imu",))


def test_pddl_names_are_valid_distinct_and_reversible() -> None:
    names = dict(pddl_names(["Cam", "cam", "3d_lidar", "and", "jaguar"]))
    assert names["jaguar"] == "jaguar"
    assert names["and"] == "c_and" and names["3d_lidar"] == "c_3d_lidar"
    assert len(set(names.values())) == 5
    assert all(n == n.lower() and n[0].isalpha() for n in names.values())


def test_kinds_inferred_from_model_yaml_match_the_ram(theory: Theory, tmp_path: Path) -> None:
    assert theory.model is not None
    from rac.pipeline import compile_model

    path = tmp_path / "model.yaml"
    path.write_text(emit_model_yaml(compile_model(theory.model), EmitOptions()), encoding="utf-8")
    from_yaml = load_theory(str(path))
    assert from_yaml.model is None
    ram, yaml = repair_system(theory), repair_system(from_yaml)
    assert yaml.components == ram.components
    # laser_alignment_node publishes nothing, so no clause shows that it drives its device.
    assert yaml.drives == (("hokuyo_node", "hokuyo"), ("jaguar_node", "jaguar"))
    assert ram.drives == (
        ("hokuyo_node", "hokuyo"),
        ("jaguar_node", "jaguar"),
        ("laser_alignment_node", "laser_alignment"),
    )


def test_kind_inference_from_clauses() -> None:
    clauses = (
        "NAB(cam) -> on(cam)",
        "NAB(cam_node) -> running(cam_node)",
        "NAB(cam_node), NAB(cam) -> ok(img)",
        "NAB(viewer) -> running(viewer)",
        "NAB(viewer), NAB(cam) -> ok(cam)",  # reports cam: not a topic, so no drive
        "NAB(imu_node), NAB(imu) -> ok(imu)",
    )
    from rac.logic import parse_clause

    parsed = tuple(parse_clause(c) for c in clauses)
    comps = ("cam", "cam_node", "imu", "imu_node", "viewer")
    system = system_from_clauses(parsed, comps)
    assert system.components == (
        ("cam", Kind.DEVICE),
        ("cam_node", Kind.NODE),
        ("imu", Kind.HARDWARE),
        ("imu_node", Kind.HARDWARE),
        ("viewer", Kind.NODE),
    )
    assert system.drives == (("cam_node", "cam"),)


def test_unrepairable_hardware_is_named(theory: Theory) -> None:
    system = RepairSystem((("cam", Kind.HARDWARE), ("cam_node", Kind.NODE)))
    problem = make_problem("tiny", system, (), ("cam",))
    prepared = prepare(theory, (), "tedusar")
    from dataclasses import replace

    with pytest.raises(NoRepairPlan, match="cam") as err:
        solve(replace(prepared, problem=problem, problem_text=render_problem(problem)))
    assert err.value.diagnostics[0].code == "RAC071"


def test_planner_reports_an_unsolvable_problem() -> None:
    system = RepairSystem((("cam", Kind.HARDWARE), ("cam_node", Kind.NODE)))
    text = render_problem(make_problem("tiny", system, (), ("cam", "cam_node")))
    with pytest.raises(NoRepairPlan, match="unsolvable") as err:
        run_planner(render_repair_domain("tiny"), text, timeout_s=30)
    assert err.value.diagnostics[0].code == "RAC075"


def _fake_planner(tmp_path: Path, body: str) -> str:
    script = tmp_path / "fake-fast-downward.py"
    script.write_text(body, encoding="utf-8")
    return str(script)


def test_planner_missing_crashing_and_timing_out(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    domain, problem = render_repair_domain("x"), "(define (problem p) (:domain x))"
    monkeypatch.setenv("RACC_FAST_DOWNWARD", str(tmp_path / "nowhere.py"))
    with pytest.raises(NoRepairPlan, match="not found"):
        run_planner(domain, problem)
    crash = "import sys\nprint('Segmentation fault in search')\nsys.exit(-11 & 0xFF)\n"
    monkeypatch.setenv("RACC_FAST_DOWNWARD", _fake_planner(tmp_path, crash))
    with pytest.raises(NoRepairPlan, match=r"(?s)planner failed.*Segmentation fault"):
        run_planner(domain, problem)
    sleep = "import time\ntime.sleep(30)\n"
    monkeypatch.setenv("RACC_FAST_DOWNWARD", _fake_planner(tmp_path, sleep))
    with pytest.raises(NoRepairPlan, match=r"within 0\.3 s") as err:
        run_planner(domain, problem, timeout_s=0.3)
    assert err.value.diagnostics[0].code == "RAC074"


def test_planner_time_limit_leaves_fast_downward_time_to_start(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """FD counts its driver's CPU in the limit: 1 s used to leave the translator 0 s."""
    argv = tmp_path / "argv.txt"
    fake = f"import sys\nopen({str(argv)!r}, 'w').write(' '.join(sys.argv))\nsys.exit(35)\n"
    monkeypatch.setenv("RACC_FAST_DOWNWARD", _fake_planner(tmp_path, fake))
    with pytest.raises(NoRepairPlan):
        run_planner(render_repair_domain("x"), "(define (problem p) (:domain x))", timeout_s=1)
    assert "--overall-time-limit 2s" in argv.read_text(encoding="utf-8")


def test_real_planner_timing_out_is_a_time_out(theory: Theory) -> None:
    prepared = prepare(theory, theta(theory, SECTION_8_4), "tedusar")
    with pytest.raises(NoRepairPlan, match=r"within 0\.001 s") as err:
        solve(prepared, timeout_s=0.001)
    assert err.value.diagnostics[0].code == "RAC074"


@pytest.mark.parametrize(
    ("code", "message"),
    [
        (11, "unsolvable"),
        (12, "unsolvable"),
        (23, "within 5 s"),
        (232, "within 5 s"),  # the translator killed by SIGXCPU
        (22, "memory"),
        (35, "exit code 35"),
    ],
)
def test_planner_exit_codes(code: int, message: str) -> None:
    assert message in _failure(code, "", 5.0).diagnostics[0].message


def test_parse_plan() -> None:
    text = "(shutdown jaguar)\n(POWER_UP jaguar)\n; cost = 2 (unit cost)\n"
    assert parse_plan(text) == (("shutdown", "jaguar"), ("power_up", "jaguar"))
    with pytest.raises(ValueError, match="not a plan step"):
        parse_plan("shutdown jaguar\n")


def test_simulation_agrees_with_unified_planning(theory: Theory) -> None:
    """Drop or swap steps of a valid plan: our semantics and UP's validator agree each time."""
    result = solve(prepare(theory, theta(theory, SECTION_8_4), "tedusar"))
    prepared, plan = result.prepared, result.plan
    variants = [plan[:i] + plan[i + 1 :] for i in range(len(plan))]
    variants += [(*plan[:i], plan[i + 1], plan[i], *plan[i + 2 :]) for i in range(len(plan) - 1)]
    variants.append((*plan, ("stop_node", "rviz")))
    for variant in variants:
        try:
            check_plan(prepared.problem, variant)
            ours = True
        except InapplicableStep:
            ours = False
        try:
            validate_plan(prepared.domain_text, prepared.problem_text, prepared.problem, variant)
            theirs = True
        except NoRepairPlan:
            theirs = False
        assert ours == theirs, variant
    assert simulate(prepared.problem, plan).bad == frozenset()


def test_power_up_effects_in_simulation(theory: Theory) -> None:
    system = repair_system(theory)
    observations = theta(theory, ("not on(jaguar)", "not running(jaguar_node)"))
    problem = make_problem("tedusar", system, observations, ("jaguar", "jaguar_node"))
    with pytest.raises(InapplicableStep, match="devices on"):
        simulate(problem, (("start_node", "jaguar_node"),))
    after = simulate(problem, (("power_up", "jaguar"),))
    assert "jaguar" in after.on and "jaguar" not in after.bad and "jaguar_node" in after.bad
    running = make_problem("tedusar", system, theta(theory, ("not on(jaguar)",)), ("jaguar",))
    after = simulate(running, (("power_up", "jaguar"),))
    assert "jaguar_node" in after.bad  # a still-running driver needs a restart after power-up


@st.composite
def repairable_problems(draw: st.DrawFn) -> RepairProblem:
    """Small systems of nodes and devices, any drives, any state, any bad set."""
    nodes = [f"n{i}" for i in range(draw(st.integers(1, 4)))]
    devices = [f"d{i}" for i in range(draw(st.integers(0, 3)))]
    pairs = [(n, d) for n in nodes for d in devices]
    drives = draw(st.lists(st.sampled_from(pairs), unique=True)) if pairs else []
    components = sorted([(n, Kind.NODE) for n in nodes] + [(d, Kind.DEVICE) for d in devices])
    system = RepairSystem(tuple(components), tuple(sorted(drives)))
    names = [c for c, _ in components]
    off = draw(st.lists(st.sampled_from(names), unique=True))
    bad = draw(st.lists(st.sampled_from(names), unique=True, min_size=1))
    observed = [Literal(Atom("running" if c in nodes else "on", (c,)), False) for c in off]
    return make_problem("prop", system, observed, bad)


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(repairable_problems())
def test_every_repairable_problem_gets_a_valid_plan(problem: RepairProblem) -> None:
    """Nodes and devices only: a plan always exists and repairs everything.

    (test_simulation_agrees_with_unified_planning ties our semantics to the PDDL's.)
    """
    text = render_problem(problem)
    domain = render_repair_domain("prop")
    run = run_planner(domain, text, timeout_s=30)
    assert check_plan(problem, run.plan).bad == frozenset()


def test_components_named_like_the_domain_still_validate() -> None:
    """unified-planning keeps types, predicates, actions and objects in one namespace."""
    names = dict(pddl_names(["node", "device", "Driver", "power_up", "at"]))
    assert names == {
        "node": "c_node",
        "device": "c_device",
        "Driver": "c_driver",
        "power_up": "c_power_up",
        "at": "at",
    }
    system = RepairSystem(
        (("device", Kind.DEVICE), ("node", Kind.NODE), ("power_up", Kind.NODE)),
        (("node", "device"),),
    )
    observed = [Literal(Atom("on", ("device",)), False), Literal(Atom("running", ("node",)), True)]
    problem = make_problem("kw", system, observed, ("device", "node"))
    text, domain = render_problem(problem), render_repair_domain("kw")
    plan = tuple(
        (s[0], *(problem.component_of()[a] for a in s[1:]))
        for s in run_planner(domain, text, timeout_s=30).plan
    )
    assert check_plan(problem, plan).bad == frozenset()
    validate_plan(domain, text, problem, plan)


def test_validator_that_cannot_read_the_problem_is_a_message(theory: Theory) -> None:
    result = solve(prepare(theory, theta(theory, SECTION_8_4), "tedusar"))
    prepared = result.prepared
    broken = prepared.problem_text.replace("- driver", "- driver\n    node - node", 1)
    with pytest.raises(NoRepairPlan, match="cannot read it") as err:
        validate_plan(prepared.domain_text, broken, prepared.problem, result.plan)
    assert err.value.diagnostics[0].code == "RAC078"


def test_power_up_planned_in_parts_is_one_valid_plan() -> None:
    """Batches of independent parts, planned apart, make a plan of the whole problem:
    checked by our semantics and by unified-planning against the whole problem's PDDL.
    (bench/repair.py --split-check does the same on 1,000 components.)"""
    from rac.diagnosis import predict
    from rac.pipeline import compile_model
    from rac.repair.scenario import power_up
    from rac.repair.split import parts, plan_in_parts

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))
    from repair import synthetic_robot  # bench/repair.py's robot: drivers and a pipeline

    compiled = compile_model(synthetic_robot(60))
    theory = Theory(compiled.rbm, compiled.props, compiled.components, model=compiled.model)
    system = repair_system(theory)
    faulty = power_up(system).faulty
    problem = make_problem("synthetic", system, predict(theory, faulty), faulty)
    assert len(parts(system)) > 10  # drivers with their devices, and lone nodes
    domain = render_repair_domain("synthetic")
    run = plan_in_parts(domain, problem, 60.0, batch=8)
    names = problem.component_of()
    plan = tuple((s[0], *(names[a] for a in s[1:])) for s in run.plan)
    assert not check_plan(problem, plan).bad
    validate_plan(domain, render_problem(problem), problem, plan)
