"""racc replay end to end: recordings not made by racc, synthetic runs with ground truth,
ROS 2 bags, the timeline file, the plot, and the errors a user meets."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import foreign_bag
import pytest

from rac.cli import main
from rac.evaluate.score import score_run
from rac.load.faults import load_truth
from rac.replay.timeline import DiagnosisRecord, ObservationRecord, Timeline
from rac.synth.truth import InjectedFault

ROOT = Path(__file__).resolve().parents[2]
PIONEER = str(ROOT / "models" / "pioneer.ram")
TEDUSAR = str(ROOT / "models" / "tedusar.ram")


def read_timeline(path: Path, duration: float) -> Timeline:
    records: list[ObservationRecord | DiagnosisRecord] = []
    for line in path.read_text().splitlines():
        doc = json.loads(line)
        assert set(doc) in ({"t", "observation"}, {"t", "diagnoses"}), doc
        if "observation" in doc:
            records.append(ObservationRecord(doc["t"], doc["observation"]))
        else:
            records.append(DiagnosisRecord(doc["t"], tuple(tuple(d) for d in doc["diagnoses"])))
    return Timeline(tuple(records), duration)


@pytest.fixture(scope="module")
def foreign(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("foreign")
    bag, csv = d / "robot.bag", d / "robot_properties.csv"
    foreign_bag.write(bag, csv)
    return bag, csv


@pytest.mark.slow
def test_a_recording_not_made_by_racc_finds_each_culprit(
    foreign: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag, csv = foreign
    out = tmp_path / "timeline.jsonl"
    assert main(["replay", PIONEER, str(bag), "--properties", str(csv), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "episode 1:" in text
    timeline = read_timeline(out, foreign_bag.DURATION)
    faults = [
        InjectedFault(what, target, start, end, (culprit,))
        for what, target, start, end, culprit in foreign_bag.FAULTS
    ]
    score = score_run(timeline, faults, grace=5.0)
    for outcome in score.outcomes:
        assert outcome.reported, outcome
        # Diagnosed while the fault lasts, and soon where the observer allows: a topic's
        # rate within about θ messages; with 1 Hz properties a crash within θ + 1.5
        # samples and an overload once the 10-sample mean passes the limit plus θ + 1
        # samples; diverging headings only once the robot turns the other way.
        soon = {"stopped topic": 4.0, "5x rate": 4.0, "crashed node": 8.0, "cpu overload": 12.0}
        assert outcome.first is not None and outcome.first <= outcome.fault.end, outcome
        bound = soon.get(outcome.fault.kind)
        if bound is not None:
            assert outcome.first <= outcome.fault.start + bound, outcome
    assert score.false_positives == ()
    # Before the first fault every observation holds and nothing is diagnosed.
    early = [r for r in timeline.records if r.t < foreign_bag.FAULTS[0][2]]
    for r in early:
        if isinstance(r, DiagnosisRecord):
            assert not r.diagnoses, r
        else:
            assert not r.literal.startswith("not_"), r


@pytest.mark.slow
def test_the_thesis_schedule_is_replayed_against_its_ground_truth(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = tmp_path / "test.bag"
    args = ["synth", PIONEER, "-o", str(run), "--duration", "300", "--seed", "3"]
    assert main([*args, "--schedule", "thesis", "-q"]) == 0
    out, png = tmp_path / "t.jsonl", tmp_path / "t.png"
    plot = ["--plot", str(png)] if _has_matplotlib() else []
    assert main(["replay", PIONEER, str(run), "-o", str(out), *plot]) == 0
    printed = capsys.readouterr().out
    truth = load_truth(tmp_path / "test.faults.yaml")
    assert truth.duration is not None
    score = score_run(read_timeline(out, truth.duration), truth.faults)
    missed = [o.fault.kind for o in score.outcomes if not o.reported]
    # A slip shows only while the robot's manoeuvre lets the two headings disagree; the
    # other faults always show.
    assert set(missed) <= {"slip"} and missed.count("slip") <= 1, missed
    assert score.false_positives == ()
    assert printed.count("fault ") == len(truth.faults)
    if plot:
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_ros2_bag_replays(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = tmp_path / "run2"
    args = ["synth", TEDUSAR, "-o", str(run), "--ros2", "--duration", "60", "-q"]
    assert main([*args, "--fault", "crash@30+20:hector_mapping"]) == 0
    assert main(["replay", TEDUSAR, str(run)]) == 0
    out = capsys.readouterr().out
    assert "diagnosed [hector_mapping]" in out
    assert "fault crash hector_mapping 30-50 s: reported" in out


def test_replay_errors(
    tmp_path: Path, short_pioneer_run: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["replay", PIONEER, str(tmp_path / "missing.bag")]) == 1
    assert "RAC080" in capsys.readouterr().err
    run = short_pioneer_run
    assert main(["replay", PIONEER, str(run), str(run), "--properties", "a.csv"]) == 1
    assert "RAC051" in capsys.readouterr().err
    other = tmp_path / "other.ram"
    other.write_text("robot other\ntopic /nothing : std_msgs/Float64 { data } @ 10 Hz\n"
                     "node n { publishes /nothing }\n")  # fmt: skip
    assert main(["replay", str(other), str(run)]) == 1
    assert "holds none of the model's topics (/nothing)" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_:
        main(["replay", PIONEER, str(run), "--diagnose-every", "0s"])
    assert exit_.value.code == 2


def test_ground_truth_is_checked_against_the_model(
    short_pioneer_run: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = short_pioneer_run
    truth = run.with_name("typo.faults.yaml")
    truth.write_text(
        "robot: pioneer\nduration: 20\nfaults:\n"
        "- {kind: crash, target: p2os, start: 5, end: 10, culprits: [p2oss]}\n"
    )
    assert main(["replay", PIONEER, str(run), "--truth", str(truth)]) == 1
    err = capsys.readouterr().err
    assert f"{truth}:4:3: error[RAC086]: culprit 'p2oss' of the crash fault is not in" in err
    assert "did you mean 'p2os'" in err
    truth.write_text("robot: tedusar\nduration: 20\nfaults: []\n")
    assert main(["replay", PIONEER, str(run), "--truth", str(truth)]) == 0
    assert "warning[RAC107]: the ground truth is for robot 'tedusar', not 'pioneer'" in (
        capsys.readouterr().err
    )


def _has_matplotlib() -> bool:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


@pytest.mark.slow
def test_the_plot_goes_to_the_file_named_in_the_format_its_suffix_names(
    short_pioneer_run: Path, tmp_path: Path
) -> None:
    """matplotlib added ``.png`` to a name without a suffix: ``--plot timeline`` wrote
    ``timeline.png`` and said nothing."""
    bare, svg = tmp_path / "timeline", tmp_path / "timeline.svg"
    for out in (bare, svg):
        assert main(["replay", PIONEER, str(short_pioneer_run), "--plot", str(out), "-q"]) == 0
    assert bare.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not (tmp_path / "timeline.png").exists()
    assert b"<svg" in svg.read_bytes()[:1000]


def test_plot_without_matplotlib_fails_before_the_replay(
    short_pioneer_run: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    import rac.replay.engine

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib: ImportError

    def no_replay(*args: object, **kwargs: object) -> None:
        raise AssertionError("replayed before finding matplotlib missing")

    monkeypatch.setattr(rac.replay.engine, "replay", no_replay)
    argv = ["replay", PIONEER, str(short_pioneer_run), "--plot", str(tmp_path / "t.png")]
    assert main(argv) == 1
    assert "error[RAC055]: --plot needs matplotlib" in capsys.readouterr().err


@pytest.mark.slow
def test_a_properties_csv_with_cr_only_line_endings_reads_as_with_lf(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A CSV whose lines end in a lone CR (an old Mac editor): csv saw one line with stray
    newlines, and replay and evaluate stopped with an internal error (exit 70)."""
    run = tmp_path / "r"
    args = ["synth", TEDUSAR, "-o", str(run), "--duration", "30", "-q"]
    assert main([*args, "--fault", "crash@10+10:hector_mapping"]) == 0
    lf = tmp_path / "r.properties.csv"
    timeline = tmp_path / "lf.jsonl"
    assert main(["replay", TEDUSAR, str(run), "-o", str(timeline), "-q"]) == 0
    assert '[["hector_mapping"]]' in timeline.read_text()
    assert main(["evaluate", "--models", TEDUSAR, "--runs", str(run), "--json", "-q"]) == 0
    expected_scores = capsys.readouterr().out
    lf.write_bytes(lf.read_bytes().replace(b"\n", b"\r"))
    cr_timeline = tmp_path / "cr.jsonl"
    args = ["replay", TEDUSAR, str(run), "--properties", str(lf), "-o", str(cr_timeline), "-q"]
    assert main(args) == 0
    assert cr_timeline.read_text() == timeline.read_text()
    assert main(["evaluate", "--models", TEDUSAR, "--runs", str(run), "--json", "-q"]) == 0
    assert capsys.readouterr().out == expected_scores
