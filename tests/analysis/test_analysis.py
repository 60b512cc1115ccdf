"""Fault modes, diagnosability analysis and observer placement (racc analyze, racc place)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from rac.analysis.analyze import analyze
from rac.analysis.place import exact_cover_cost, place
from rac.cli import main
from rac.diagnosis import simulate
from rac.errors import RacError
from rac.load.theory import load_theory

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = str(ROOT / "models" / "tedusar.ram")
PIONEER = str(ROOT / "models" / "pioneer.ram")
LOOP = str(ROOT / "tests" / "models" / "odometry_loop.ram")


def test_crash_mode_is_the_historical_simulation() -> None:
    theory = load_theory(TEDUSAR)
    for c in theory.components:
        crash = simulate(theory, [c], mode="crash")
        assert simulate(theory, [c]).observations == crash.observations


def test_output_mode_keeps_running_and_limits() -> None:
    theory = load_theory(LOOP)
    sim = simulate(theory, ["laser_scan_matching"], mode="output")
    bad = {str(o) for o in sim.observations if not o.positive}
    assert "not_ok(odom)" in bad and "not_ok(corrected_odometry_pose)" in bad
    assert not any(b.startswith(("not_running", "not_ok(laser_scan_matching,")) for b in bad)
    assert sim.detected and sim.mode == "output"


def test_silent_hardware_keeps_on_and_kills_the_drivers_topics() -> None:
    theory = load_theory(LOOP)
    bad = {str(o) for o in simulate(theory, ["base"], mode="silent-hardware").observations}
    assert "on(base)" in bad and "not_ok(odom)" in bad and "not_ok(base)" in bad


def test_a_mode_that_does_not_apply_is_an_error() -> None:
    with pytest.raises(RacError, match="cannot fail"):
        simulate(load_theory(LOOP), ["base"], mode="output")


def test_analysis_scores_and_groups() -> None:
    a = analyze(load_theory(TEDUSAR), "output")
    # Since the speed/orientation relation left the model, no observer links the teleop
    # node with the IMU: its wrong output goes unseen, and no two faults look alike.
    assert a.groups == ()
    assert a.detectable == 4 and a.isolable == 4 and len(a.faults) == 7
    teleop = next(f for f in a.faults if f.component == "jaguar_teleop_node")
    assert not teleop.detectable
    jaguar = next(f for f in a.faults if f.component == "jaguar_node")
    assert jaguar.cone == ("map", "pose")


def test_analysis_agrees_with_simulation_on_detection() -> None:
    theory = load_theory(PIONEER)
    for mode in ("crash", "output"):
        for f in analyze(theory, mode).faults:
            assert f.detectable == simulate(theory, [f.component], mode=mode).detected


@pytest.mark.parametrize("path", [TEDUSAR, PIONEER, LOOP])
def test_placement_isolates_and_is_optimal(path: str) -> None:
    p = place(load_theory(path), "output")
    weights = [c.cost for c in p.candidates]
    assert p.cost <= 1.1 * p.lp_bound + 1e-6
    assert p.cost == pytest.approx(exact_cover_cost(p.requirements, weights))
    solvable = {r.fault for r in p.unresolvable}
    for f in p.after.faults:
        if f.component not in solvable:
            assert f.isolable, f


def test_placement_makes_tedusar_and_pioneer_fully_isolable() -> None:
    for path in (TEDUSAR, PIONEER):
        after = place(load_theory(path), "output").after
        assert after.isolable == after.detectable == len(after.faults)


def test_budget_limits_the_cost() -> None:
    p = place(load_theory(TEDUSAR), "output", budget=1)
    assert p.cost <= 1 and len(p.chosen) == 1


def test_cli_analyze_json_and_dot(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["analyze", PIONEER, "--mode", "crash", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["analyses"][0]["mode"] == "crash"
    # A crashed driver and its dead device look alike when nothing else tells them apart.
    groups = [["lms200", "sicklms"], ["p2os", "pioneer_base"]]
    assert doc["analyses"][0]["ambiguity_groups"] == groups
    assert main(["analyze", PIONEER, "--mode", "crash", "--dot"]) == 0
    assert "fillcolor" in capsys.readouterr().out


def test_cli_place_patch_applies(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "pioneer.patch"
    assert main(["place", PIONEER, "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "LP lower bound" in err and "after: detectable 6/6, isolable 6/6" in err
    text = out.read_text()
    assert "racc place (output)" in text
    # no made-up rate on a topic of unknown regularity (issue 26): the patch says to measure
    assert "+# racc place: no rate written: if /map is periodic" in text
    assert "+topic" not in text and "rates to measure (racc record, racc learn): " in err


def test_cli_place_bad_costs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    costs = tmp_path / "costs.yaml"
    costs.write_text("GObs: -1\n")
    assert main(["place", PIONEER, "--costs", str(costs)]) == 1
    assert "RAC062" in capsys.readouterr().err


def test_costs_steer_the_choice(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    costs = tmp_path / "costs.yaml"
    costs.write_text("GObs /map: 50\n")
    assert main(["place", TEDUSAR, "--costs", str(costs), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["cost"] >= 3


def test_learned_candidates_give_values_and_pairs(tmp_path: Path) -> None:
    from rac.analysis.place import candidates
    from rac.load.files import load_model

    text = Path(LOOP).read_text()
    text = text.replace(
        "topic /map : nav_msgs/OccupancyGrid", "topic /map : nav_msgs/OccupancyGrid @ 2 Hz"
    )
    text += "relate /scan.ranges ~ /corrected_odometry_pose.yaw\n"
    learned = tmp_path / "learned.ram"
    learned.write_text(text)
    model = load_theory(LOOP).model
    assert model is not None
    cands = {c.name: c for c in candidates(model, load_model(str(learned)))}
    assert cands["GObs /map"].value == 2.0 and cands["GObs /map"].learned
    assert "BiQObs /scan.ranges ~ /corrected_odometry_pose.yaw" in cands
    out = tmp_path / "patch"
    assert main(["place", LOOP, "--candidates", str(learned), "-o", str(out)]) == 0
    assert "topic /map : nav_msgs/OccupancyGrid @ 2 Hz" in out.read_text()


def test_a_topic_learned_without_a_rate_gets_no_gobs(tmp_path: Path) -> None:
    from rac.analysis.place import candidates
    from rac.load.files import load_model

    model = load_model(TEDUSAR)
    text = Path(TEDUSAR).read_text()
    # the recording: /map came at a steady 2 Hz, /joy and /cmd_vel had no steady rate
    text = text.replace(
        "{ info.width, info.height, data }", "{ info.width, info.height, data } @ 2 Hz"
    )
    learned = tmp_path / "learned.ram"
    learned.write_text(text)
    unlearned = {c.name for c in candidates(model)}
    assert {"GObs /joy", "GObs /cmd_vel", "GObs /map"} <= unlearned
    with_learned = {c.name: c for c in candidates(model, load_model(str(learned)))}
    assert "GObs /joy" not in with_learned and "GObs /cmd_vel" not in with_learned
    assert with_learned["GObs /map"].value == 2.0
