"""Messy real-world files: a byte-order mark, an oversized input, YAML beyond the limits in
every file racc reads with PyYAML, and an output directory that holds the working directory.
Each ends in a coded error (exit 1), never in a traceback, a MemoryError or a lost directory."""

from __future__ import annotations

import argparse
import os
import re
from pathlib import Path

import pytest

from rac.cli import main
from rac.errors import RacError
from rac.load import files as loader

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = ROOT / "models" / "tedusar.ram"
PIONEER = ROOT / "models" / "pioneer.ram"

# More nesting than the 64 levels the limits allow, and a "billion laughs" file: nine
# aliases of nine aliases... (9**8 strings once expanded; the file itself is tiny).
TOO_DEEP = "[" * 100 + "]" * 100 + "\n"
# Deeper than libyaml's own 1,000 levels: libyaml refused these, and the pure-Python PyYAML
# racc then read them with to say why recursed (RecursionError, exit 70).
DEEPER_THAN_LIBYAML = "a: " + "[" * 1000 + "\n"
BLOCKS_DEEPER_THAN_LIBYAML = "".join("  " * i + "-\n" for i in range(1001))
LAUGHS = 'a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]\n' + "".join(
    f"{c}: &{c} [{', '.join([f'*{p}'] * 9)}]\n" for p, c in zip("abcdefg", "bcdefgh", strict=True)
)


def _codes(err: str) -> set[str]:
    return {line.split("error[")[1][:6] for line in err.splitlines() if "error[" in line}


def test_byte_order_mark_is_ignored(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = tmp_path / "bom.ram"
    model.write_bytes(b"\xef\xbb\xbf" + TEDUSAR.read_bytes().replace(b"\n", b"\r\n"))
    obs = tmp_path / "obs.txt"
    obs.write_bytes(b"\xef\xbb\xbfnot ok(pose)\r\n")
    assert main(["check", str(model)]) == 0
    assert main(["diagnose", str(model), "--obs-file", str(obs), "-q"]) == 0
    assert "fault detected" in capsys.readouterr().out


def test_observations_not_utf8_are_located(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    obs = tmp_path / "obs.txt"
    obs.write_bytes(b"ok(pose)\nnot ok(sc\xe4n)\n")
    assert main(["diagnose", str(TEDUSAR), "--obs-file", str(obs)]) == 1
    err = capsys.readouterr().err
    assert f"{obs}:2:10: error[RAC004]: not UTF-8 text: byte 0xe4" in err


def test_an_oversized_input_is_refused_unread(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # /dev/zero never ends: racc used to read it until the memory ran out.
    monkeypatch.setattr(loader, "MAX_INPUT_BYTES", 1 << 20)
    assert main(["check", "/dev/zero"]) == 1
    assert "error[RAC009]: /dev/zero: larger than 1 MiB" in capsys.readouterr().err


def test_an_oversized_regular_file_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(loader, "MAX_INPUT_BYTES", 1000)
    big = tmp_path / "big.ram"
    big.write_text("robot r\n" + "# a comment line\n" * 100, encoding="utf-8")
    assert main(["check", str(big)]) == 1
    assert f"error[RAC009]: {big}: larger than" in capsys.readouterr().err


def test_a_small_file_is_read_without_allocating_the_limit(tmp_path: Path) -> None:
    """``read(limit + 1)`` allocated the whole 256 MiB limit for every file it read."""
    import tracemalloc

    small = tmp_path / "small.ram"
    small.write_text(Path(TEDUSAR).read_text(encoding="utf-8"), encoding="utf-8")
    tracemalloc.start()
    try:
        loader.read_text(small)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1 << 20


@pytest.mark.parametrize(
    "text",
    [TOO_DEEP, LAUGHS, DEEPER_THAN_LIBYAML, BLOCKS_DEEPER_THAN_LIBYAML],
    ids=["too_deep", "aliases", "deeper_than_libyaml", "blocks_deeper_than_libyaml"],
)
def test_yaml_files_read_within_the_limits(
    text: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Faults files, observers.yaml, tug configurations, placement costs, model.yaml and
    computation graphs: RAC009, located."""
    path = tmp_path / "hostile.yaml"
    path.write_text(text, encoding="utf-8")
    truth = tmp_path / "r.faults.yaml"
    truth.write_text(text, encoding="utf-8")
    from rac.load.faults import load_truth

    with pytest.raises(RacError) as raised:
        load_truth(truth)
    assert [d.code for d in raised.value.diagnostics] == ["RAC009"]
    assert raised.value.diagnostics[0].span is not None
    commands = [
        ["observe", str(path)],
        ["repairer", str(TEDUSAR), "--observers", str(path)],
        ["import", "tug", str(path), "-o", str(tmp_path / "imported.ram")],
        ["place", str(TEDUSAR), "--costs", str(path)],
        ["replay", str(TEDUSAR), str(tmp_path / "r"), "--truth", str(path)],
        ["diagnose", str(path), "--obs", "ok(a)"],
    ]
    for argv in commands:
        assert main(argv) == 1, argv
        err = capsys.readouterr().err
        assert _codes(err) == {"RAC009"}, (argv, err)
        assert re.search(rf"^{re.escape(str(path))}:\d+:\d+: error\[RAC009\]", err, re.M), err
    assert not (tmp_path / "imported.ram").exists()


@pytest.mark.parametrize(
    "text",
    [TOO_DEEP, DEEPER_THAN_LIBYAML, BLOCKS_DEEPER_THAN_LIBYAML],
    ids=["too_deep", "deeper_than_libyaml", "blocks_deeper_than_libyaml"],
)
def test_yaml_beside_a_run_or_for_learn_within_the_limits(
    text: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The faults file `evaluate` finds beside a run (RAC009, located), and `learn --graph`
    (RAC081, naming the file and its line)."""
    run = tmp_path / "r"
    assert main(["synth", str(TEDUSAR), "-o", str(run), "--duration", "2", "-q"]) == 0
    faults = tmp_path / "r.faults.yaml"
    faults.write_text(text, encoding="utf-8")
    assert main(["evaluate", "--models", str(TEDUSAR), "--runs", str(run), "-q"]) == 1
    err = capsys.readouterr().err
    assert _codes(err) == {"RAC009"}, err
    assert re.search(rf"^{re.escape(str(faults))}:\d+:\d+: error\[RAC009\]", err, re.M), err
    graph = tmp_path / "graph.yaml"
    graph.write_text(text, encoding="utf-8")
    assert main(["learn", str(run), "--graph", str(graph), "-o", str(tmp_path / "m.ram")]) == 1
    err = capsys.readouterr().err
    assert _codes(err) == {"RAC081"} and str(graph) in err and "line " in err, err


@pytest.mark.parametrize("output", [".", "", ".."])
def test_output_directory_holding_the_working_directory(
    output: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """`-o .` used to move the working directory aside and delete it (the shell that ran racc
    was left in a removed directory); now it is refused and nothing changes."""
    work = tmp_path / "work"
    work.mkdir()
    (work / "notes.txt").write_text("mine\n")
    monkeypatch.chdir(work)
    inode = os.stat(work).st_ino
    assert main(["compile", str(TEDUSAR), "-o", output, "--no-svg"]) == 1
    assert "error[RAC004]" in capsys.readouterr().err
    assert os.stat(work).st_ino == inode and Path.cwd().exists()
    assert sorted(p.name for p in work.iterdir()) == ["notes.txt"]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".racc-")]


def test_synth_force_replaces_only_a_recording(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`racc synth -o DIR --force` used to remove any directory (`-o ~ --force`: the home)."""
    stuff = tmp_path / "stuff"
    stuff.mkdir()
    (stuff / "precious.txt").write_text("mine\n")
    args = ["synth", str(TEDUSAR), "-o", str(stuff), "--duration", "2", "--force", "-q"]
    assert main(args) == 1
    assert "error[RAC084]" in capsys.readouterr().err
    assert (stuff / "precious.txt").read_text() == "mine\n"
    assert not (tmp_path / "stuff.faults.yaml").exists()
    # A previous recording (and an empty directory) is replaced as before.
    run = tmp_path / "run"
    run.mkdir()
    args[3] = str(run)
    assert main(args) == 0
    assert main(args) == 0
    assert sorted(p.name for p in run.iterdir()) == ["metadata.yaml", "run.db3"]


def test_synth_under_a_file_is_an_input_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "afile").write_text("")
    out = tmp_path / "afile" / "x.bag"
    assert main(["synth", str(TEDUSAR), "-o", str(out), "--duration", "2", "-q"]) == 1
    assert "error[RAC004]" in capsys.readouterr().err


def test_replay_drops_property_samples_far_outside_the_recording(
    short_pioneer_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A sample at 1e300 s (or a CSV of another run, hours later) stepped the observers all
    the way there: replay never ended.  Such samples are dropped, with a note."""
    csv = short_pioneer_run.with_name("r.properties.csv")
    lines = csv.read_text(encoding="utf-8").splitlines()
    node = lines[1].split(",")[1]
    far = tmp_path / "far.csv"
    far.write_text("\n".join([*lines, f"2000,{node},1,1000000"]) + "\n", encoding="utf-8")
    assert main(["replay", str(PIONEER), str(short_pioneer_run), "--properties", str(far)]) == 0
    captured = capsys.readouterr()
    assert "1 sample outside the recording's" in captured.err
    assert "20.0 s" in captured.out


@pytest.mark.parametrize("period", ["1e-9", "1e-12", "0.0000001s", "0.5ms"])
def test_a_diagnosis_period_too_short_is_refused(period: str) -> None:
    """--diagnose-every 1e-9 made replay tick 2*10^10 times (and at 1e-12 the clock stood)."""
    from rac.commands.options import period as seconds

    with pytest.raises(argparse.ArgumentTypeError, match="must be from 1 ms to 3600 s"):
        seconds(period)
    assert seconds("1ms") == 0.001


def test_a_diagnosis_period_too_short_is_a_command_line_error(
    short_pioneer_run: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as caught:
        main(["replay", str(PIONEER), str(short_pioneer_run), "--diagnose-every", "0.5ms"])
    assert caught.value.code == 2
    assert "must be from 1 ms to 3600 s" in capsys.readouterr().err


def test_rewritten_and_new_files_keep_the_usual_modes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Files were written through mkstemp and so left 0600: `racc fmt` made a shared model
    unreadable to the robot's other users, and every new output was private."""
    model = tmp_path / "m.ram"
    model.write_text(TEDUSAR.read_text(encoding="utf-8").replace("hardware imu", "hardware  imu"))
    model.chmod(0o640)
    assert main(["fmt", str(model)]) == 0
    assert model.stat().st_mode & 0o777 == 0o640
    umask = os.umask(0o022)
    try:
        assert main(["export", "--ram", str(model), "-o", str(tmp_path / "new.ram")]) == 0
    finally:
        os.umask(umask)
    assert (tmp_path / "new.ram").stat().st_mode & 0o777 == 0o644
    assert main(["export", "--ram", str(model), "-o", str(tmp_path)]) == 1
    assert "is a directory; give a file name" in capsys.readouterr().err


def test_replay_refuses_a_recording_with_a_time_stamp_far_off(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """One message stamped near 1970 in a bag of 2020: replay stepped the observers through
    fifty years in 0.1 s steps and never ended."""
    import sqlite3

    run = tmp_path / "run"
    assert main(["synth", str(TEDUSAR), "-o", str(run), "--duration", "3", "-q"]) == 0
    with sqlite3.connect(run / "run.db3") as db:
        db.execute("UPDATE messages SET timestamp = 1000 WHERE id = 5")
    from rac.commands.common import load_and_compile
    from rac.replay.load import needs_of, replayable
    from rac.replay.sources import load_run

    needs = needs_of([replayable(load_and_compile(str(TEDUSAR), quiet=True))])
    with pytest.raises(RacError):  # before the replay itself (which would not end)
        load_run(str(run), needs, None)
    assert main(["replay", str(TEDUSAR), str(run), "-q"]) == 1
    err = capsys.readouterr().err
    assert "error[RAC080]" in err and "a time stamp is far off" in err
    # learning would take its rates and windows from fifty years: the same error
    assert main(["learn", str(run), "--base", str(TEDUSAR), "-o", str(tmp_path / "l.ram")]) == 1
    err = capsys.readouterr().err
    assert "error[RAC080]" in err and "a time stamp is far off" in err
    assert not (tmp_path / "l.ram").exists()


def test_a_recording_with_a_wrong_topic_type_says_what_broke(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A topic whose type was edited in the bag's index: the message was only the bare key
    "'sensor_msgs/msg/Imu'"."""
    import sqlite3

    run = tmp_path / "run"
    assert main(["synth", str(TEDUSAR), "-o", str(run), "--duration", "2", "-q"]) == 0
    with sqlite3.connect(run / "run.db3") as db:
        db.execute("UPDATE topics SET type = 'std_msgs/msg/String' WHERE name = '/imu_data'")
    assert main(["replay", str(TEDUSAR), str(run), "-q"]) == 1
    err = capsys.readouterr().err
    assert "error[RAC080]" in err and "damaged or inconsistent (KeyError: " in err


def test_unusable_paths_are_input_errors(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A loop of symbolic links or a name longer than the file system allows were bug
    reports (exit 70: RuntimeError, OSError ENAMETOOLONG from Path.exists or resolve)."""
    monkeypatch.chdir(tmp_path)
    Path("loop").symlink_to("loop")
    long = "x" * 300
    model = str(TEDUSAR)
    commands = [
        ["compile", model, "-o", "loop", "-q"],
        ["compile", model, "-o", long, "-q"],
        ["export", "--ram", model, "-o", f"loop/{long}"],
        ["ros-package", "-o", "loop", "--ros", "1", "-q"],
        ["synth", model, "-o", long, "--duration", "2", "-q"],
        ["synth", model, "-o", f"{long}.bag", "--duration", "2", "-q"],
        ["replay", model, long, "-q"],
        ["learn", long, "--base", model, "-o", "learned.ram", "-q"],
    ]
    for argv in commands:
        assert main(argv) == 1, argv
        err = capsys.readouterr().err
        assert "error[RAC004]" in err or "error[RAC080]" in err, (argv, err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["loop"]


def test_replay_says_when_the_recording_lacks_a_field_the_observers_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A relation on a field the recorded message type does not have: its observer stayed
    silent for the whole replay, and nothing said so ("no fault diagnosed")."""
    run = tmp_path / "run"
    assert main(["synth", str(TEDUSAR), "-o", str(run), "--duration", "3", "-q"]) == 0
    text = TEDUSAR.read_text(encoding="utf-8")
    text = text.replace("twist.twist.angular.z, yaw\n", "twist.twist.angular.z, yaw, bogus\n", 1)
    text = text.replace("relate /imu_data.yaw ~ /pose.yaw", "relate /imu_data.yaw ~ /pose.bogus")
    model = tmp_path / "bogus.ram"
    model.write_text(text, encoding="utf-8")
    assert main(["replay", str(TEDUSAR), str(run)]) == 0
    assert "which has no" not in capsys.readouterr().err
    assert main(["replay", str(model), str(run)]) == 0
    err = capsys.readouterr().err
    assert "/pose is recorded as nav_msgs/Odometry, which has no bogus" in err


def test_learn_quiet_prints_nothing_on_success(
    short_pioneer_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`learn -q` ("print nothing on success") still printed its notes on stderr."""
    out = tmp_path / "learned.ram"
    args = ["learn", str(short_pioneer_run), "--base", str(PIONEER), "-o", str(out)]
    assert main(args) == 0
    assert "note:" in capsys.readouterr().err  # the run has notes to tell
    assert main([*args, "-q"]) == 0
    assert capsys.readouterr() == ("", "")


def test_an_mcap_bag_with_a_damaged_length_is_an_input_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A record length of 2**62 in an MCAP file: rosbags asked for that much memory, and the
    MemoryError was a bug report (exit 70)."""
    import struct

    run = tmp_path / "run"
    args = ["synth", str(TEDUSAR), "-o", str(run), "--duration", "2", "--storage", "mcap", "-q"]
    assert main(args) == 0
    mcap = run / "run.mcap"
    data = mcap.read_bytes()
    assert data[:9] == b"\x89MCAP0\r\n\x01"  # magic, then the header record's opcode
    mcap.write_bytes(data[:9] + struct.pack("<Q", 1 << 62) + data[17:])
    for argv in (
        ["replay", str(TEDUSAR), str(run)],
        ["learn", str(run), "-o", str(tmp_path / "x.ram")],
    ):
        assert main([*argv, "-q"]) == 1
        err = capsys.readouterr().err
        assert "error[RAC080]" in err and "ran out of memory" in err


def _damaged_run_fails_cleanly(
    run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], *expected: str
) -> None:
    for argv in (
        ["replay", str(TEDUSAR), str(run)],
        ["learn", str(run), "-o", str(tmp_path / "x.ram")],
    ):
        assert main([*argv, "-q"]) == 1, argv
        err = capsys.readouterr().err
        assert "error[RAC080]" in err and all(e in err for e in expected), err


def test_a_sqlite3_bag_damaged_inside_a_page_is_an_input_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """One cell pointer of a table page in the middle of the database: SQLite opens it and
    counts its rows, then meets the damage while the messages are read (apsw.CorruptError
    was a bug report, exit 70)."""
    run = tmp_path / "run"
    args = ["synth", str(TEDUSAR), "-o", str(run), "--duration", "5", "--ros2", "-q"]
    assert main(args) == 0
    database = run / "run.db3"
    data = bytearray(database.read_bytes())
    page_size = int.from_bytes(data[16:18], "big")
    pages = len(data) // page_size
    leaf = next(p for p in range(pages // 2, pages) if data[p * page_size] == 0x0D)
    data[leaf * page_size + 10] = 0xFF  # the second cell now lies beyond its page
    database.write_bytes(bytes(data))
    _damaged_run_fails_cleanly(run, tmp_path, capsys, "run.db3: its SQLite database is damaged")


def test_an_mcap_length_beyond_any_read_is_an_input_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """One byte: the header record's length becomes 2**63 or more, which no read takes
    (OverflowError from inside rosbags was a bug report, exit 70)."""
    run = tmp_path / "run"
    args = ["synth", str(TEDUSAR), "-o", str(run), "--duration", "2", "--storage", "mcap", "-q"]
    assert main(args) == 0
    mcap = run / "run.mcap"
    data = bytearray(mcap.read_bytes())
    assert data[:9] == b"\x89MCAP0\r\n\x01"  # magic, then the header record's opcode
    data[16] = 0x80  # the length's most significant byte
    mcap.write_bytes(bytes(data))
    _damaged_run_fails_cleanly(run, tmp_path, capsys, "run.mcap: a length in it is damaged")


def test_an_mcap_file_cut_after_its_magic_is_an_input_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """An MCAP file of its 8 magic bytes alone (a copy cut short): rosbags read the next
    record's opcode from nothing, and the TypeError of ord('') was a bug report (exit 70;
    bench/fuzz.py, make_case('mcap', 1002651))."""
    run = tmp_path / "run"
    args = ["synth", str(TEDUSAR), "-o", str(run), "--duration", "2", "--storage", "mcap", "-q"]
    assert main(args) == 0
    mcap = run / "run.mcap"
    mcap.write_bytes(mcap.read_bytes()[:8])
    _damaged_run_fails_cleanly(run, tmp_path, capsys, "run.mcap: damaged (TypeError: ord()")


def test_an_error_in_racc_reading_a_bag_stays_an_internal_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Only what the reader library raises on a file's bytes is the file's fault: the same
    TypeError raised in racc's own code is a bug, and is not called a damaged recording."""
    from rac.learn.fields import FieldSelector
    from rac.load import bags

    run = tmp_path / "run"
    args = ["synth", str(TEDUSAR), "-o", str(run), "--duration", "2", "--storage", "mcap", "-q"]
    assert main(args) == 0

    def broken(*_: object) -> object:
        raise TypeError("a bug of racc's")

    monkeypatch.setattr(bags, "_read", broken)
    with pytest.raises(TypeError, match="a bug of racc's"):
        bags.read_run(run, FieldSelector())


@pytest.mark.parametrize("depth", [100, 600, 1200])
def test_a_rosbag2_metadata_yaml_nested_deep_is_an_input_error(
    depth: int, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """rosbags reads metadata.yaml with a recursive YAML reader: nested 600 deep it ran out of
    stack (RecursionError, exit 70).  RAC080 at the line of the metadata.yaml."""
    run = tmp_path / "run"
    assert main(["synth", str(TEDUSAR), "-o", str(run), "--duration", "2", "--ros2", "-q"]) == 0
    metadata = run / "metadata.yaml"
    text = metadata.read_text(encoding="utf-8")
    assert "  custom_data: null\n" in text
    deep = "[" * depth + "]" * depth
    metadata.write_text(text.replace("custom_data: null", f"custom_data: {deep}"), "utf-8")
    line = text[: text.index("custom_data")].count("\n") + 1
    _damaged_run_fails_cleanly(run, tmp_path, capsys, f"{metadata}:{line}:", "nest more than")


def test_safe_yaml_loads_what_safe_load_loads_and_fails_as_it_does() -> None:
    """Within the limits the document is read by libyaml's loader: the same data as
    ``yaml.safe_load``; a text that is not YAML fails with PyYAML's own error."""
    import yaml

    from rac.commands.common import load_and_compile
    from rac.limits import safe_yaml
    from rac.targets import EmitOptions
    from rac.targets.observers_yaml import emit_observers_yaml

    text = emit_observers_yaml(load_and_compile(str(TEDUSAR), quiet=True), EmitOptions())
    assert safe_yaml(text, "observers.yaml") == yaml.safe_load(text)
    broken = "observers: [a, b\nname: x\n"
    with pytest.raises(yaml.YAMLError) as ours:
        safe_yaml(broken, "o.yaml")
    with pytest.raises(yaml.YAMLError) as theirs:
        yaml.safe_load(broken)
    assert str(ours.value) == str(theirs.value)


def test_demo_output_that_is_a_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`racc demo -o FILE` was an internal error (FileExistsError, exit 70); now RAC004 and
    the file is left as it was."""
    taken = tmp_path / "taken"
    taken.write_text("mine\n")
    args = ["demo", str(TEDUSAR), "--ros", "1", "-o", str(taken), "--write-only"]
    assert main(args) == 1
    err = capsys.readouterr().err
    assert "error[RAC004]" in err and "exists and is not a directory" in err, err
    assert taken.read_text() == "mine\n"
