"""The command line: help, version, compile, fmt, export, exit codes (contract §4, §7)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from rac import __version__
from rac.cli import main
from rac.fmt import format_model
from rac.interchange import model_to_json
from rac.load.files import load_model
from rac.targets import targets

ROOT = Path(__file__).resolve().parents[2]
MODELS = sorted((ROOT / "models").glob("*.ram"))
TEDUSAR = ROOT / "models" / "tedusar.ram"
CONTRACT_FILES = {
    "model.yaml",
    "observers.yaml",
    "observers.launch",
    "observers.launch.xml",
    "repair_domain.pddl",
    "architecture.dot",
}
HAVE_DOT = shutil.which("dot") is not None
COMMANDS = ("compile", "check", "export", "fmt")


def racc(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """The installed console script, in a fresh process."""
    exe = Path(sys.executable).with_name("racc")
    command = [str(exe)] if exe.exists() else [sys.executable, "-m", "rac"]
    return subprocess.run(
        [*command, *args],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        env={**os.environ, **(env or {})},
        cwd=ROOT,
    )


def run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    """``racc ARGS`` in process: (exit code, stdout, stderr)."""
    try:
        code = main(list(args))
    except SystemExit as exit_:
        code = exit_.code if isinstance(exit_.code, int) else 1
    out = capsys.readouterr()
    return code, out.out, out.err


# --- help and version -------------------------------------------------------------------------


@pytest.mark.slow
def test_console_script_help_and_version() -> None:
    done = racc("--help")
    assert done.returncode == 0
    assert "usage: racc" in done.stdout
    for command in COMMANDS:
        assert command in done.stdout
    assert "racc compile models/tedusar.ram" in done.stdout
    version = racc("--version")
    assert version.returncode == 0
    assert version.stdout.strip() == f"racc {__version__}"
    assert __version__[0].isdigit()


@pytest.mark.parametrize("command", COMMANDS)
def test_each_command_help_has_an_example(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, command, "--help")
    assert code == 0
    assert f"usage: racc {command}" in out
    examples = out.split("examples:", 1)
    assert len(examples) == 2, f"racc {command} --help has no examples section"
    assert f"racc {command} " in examples[1]


def test_no_command_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys)
    assert code == 2
    assert "usage: racc" in err


@pytest.mark.parametrize(
    "args",
    [
        ("frobnicate",),
        ("compile",),
        ("compile", str(TEDUSAR), "--no-such-option"),
        ("export", str(TEDUSAR)),  # neither --json nor --ram
        ("export", "--json", "--ram", str(TEDUSAR)),
        ("--no-such-flag",),
    ],
)
def test_bad_command_line_exits_2(
    args: tuple[str, ...], capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, err = run(capsys, *args)
    assert code == 2, (out, err)
    assert "usage:" in err


def test_bad_command_line_exits_2_in_a_process() -> None:
    done = racc("compile", "--no-such-option", str(TEDUSAR))
    assert done.returncode == 2
    assert "usage:" in done.stderr


# --- compile ----------------------------------------------------------------------------------


def test_targets_write_the_contract_files() -> None:
    assert {t.filename for t in targets()} == CONTRACT_FILES


@pytest.mark.parametrize("model", MODELS, ids=lambda p: p.stem)
def test_compile_writes_exactly_the_contract_files(
    model: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    code, stdout, _ = run(capsys, "compile", str(model), "-o", str(out))
    assert code == 0
    expected = CONTRACT_FILES | ({"architecture.svg"} if HAVE_DOT else set())
    assert {p.name for p in out.iterdir()} == expected
    assert all((out / name).stat().st_size > 0 for name in expected)
    for name in expected:
        assert name in stdout
    if HAVE_DOT:
        assert b"<svg" in (out / "architecture.svg").read_bytes()[:2000]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"], "temporary files left behind"


def test_compile_no_svg_and_quiet(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    code, stdout, stderr = run(capsys, "compile", str(TEDUSAR), "-o", str(out), "--no-svg", "-q")
    assert code == 0
    assert (stdout, stderr) == ("", "")
    assert {p.name for p in out.iterdir()} == CONTRACT_FILES


def test_compile_into_an_existing_directory_replaces_the_files(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "model.yaml").write_text("stale\n")
    (out / "keep.txt").write_text("mine\n")
    assert run(capsys, "compile", str(TEDUSAR), "-o", str(out), "--no-svg", "-q")[0] == 0
    assert (out / "model.yaml").read_text() != "stale\n"
    assert (out / "keep.txt").read_text() == "mine\n"


def test_ros_package_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    args = ("compile", str(TEDUSAR), "-o", str(out), "--no-svg", "-q", "--ros-package", "my_obs")
    assert run(capsys, *args)[0] == 0
    for name in ("observers.launch", "observers.launch.xml"):
        text = (out / name).read_text()
        assert 'pkg="my_obs"' in text
        assert "tug_ist_diagnosis_observers" not in text


def test_default_launch_starts_the_racc_runtime(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    assert run(capsys, "compile", str(TEDUSAR), "-o", str(out), "--no-svg", "-q")[0] == 0
    text = (out / "observers.launch").read_text()
    text2 = (out / "observers.launch.xml").read_text()
    for exe in ("observe", "engine", "repairer", "board_client"):
        assert f'pkg="racc" type="{exe}"' in text
        assert f'pkg="racc" exec="{exe}"' in text2
    assert "tug_ist" not in text and "tug_ist" not in text2
    stack = tmp_path / "stack"
    args = ("compile", str(TEDUSAR), "-o", str(stack), "--no-svg", "-q")
    assert run(capsys, *args, "--model-server-package", "my_server")[0] == 0
    text = (stack / "observers.launch").read_text()
    assert 'pkg="my_server" type="diagnosis_model_server.py"' in text
    assert 'pkg="tug_ist_diagnosis_observers" type="GObs.py"' in text
    text2 = (stack / "observers.launch.xml").read_text()
    assert 'pkg="my_server" exec="diagnosis_model_server.py"' in text2
    assert 'pkg="tug_ist_diagnosis_observers" exec="GObs.py"' in text2


def test_two_compiles_are_byte_identical(tmp_path: Path) -> None:
    """Separate processes with different hash seeds write the same bytes (contract §4)."""
    outs = []
    for seed in ("1", "4242"):
        out = tmp_path / f"out{seed}"
        done = racc("compile", str(TEDUSAR), "-o", str(out), env={"PYTHONHASHSEED": seed})
        assert done.returncode == 0, done.stderr
        outs.append({p.name: p.read_bytes() for p in sorted(out.iterdir())})
    assert outs[0].keys() == outs[1].keys()
    for name in outs[0]:
        assert outs[0][name] == outs[1][name], f"{name} differs between runs"


@pytest.mark.parametrize("model", MODELS, ids=lambda p: p.stem)
def test_compile_from_json_export_gives_the_same_files(
    model: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    json_path = tmp_path / f"{model.stem}.json"
    assert run(capsys, "export", "--json", str(model), "-o", str(json_path))[0] == 0
    for source, out in ((model, tmp_path / "a"), (json_path, tmp_path / "b")):
        assert run(capsys, "compile", str(source), "-o", str(out), "--no-svg", "-q")[0] == 0
    for name in CONTRACT_FILES:
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name


def test_compile_bad_model_exits_1_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.ram"
    bad.write_text("robot r\nnode n drives nothing {}\n")
    out = tmp_path / "out"
    code, _, stderr = run(capsys, "compile", str(bad), "-o", str(out))
    assert code == 1
    assert f"{bad}:2:15: error[RAC011]" in stderr
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.ram"]


def test_check_reports_ok(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "check", str(TEDUSAR))
    assert code == 0
    assert "ok" in out and "9 nodes" in out


# --- fmt --------------------------------------------------------------------------------------

MESSY = (
    "robot   r # the robot\nhardware imu\nnode n drives imu{publishes /x;limits mem 1 MB}\n"
    "topic /x\n"
)


def test_fmt_check_diff_and_rewrite(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "messy.ram"
    path.write_text(MESSY)
    code, _, err = run(capsys, "fmt", "--check", str(path))
    assert code == 1 and "messy.ram" in err
    assert path.read_text() == MESSY

    code, out, _ = run(capsys, "fmt", "--diff", str(path))
    assert code == 1  # a change is pending: as ruff format --diff and --check
    assert out.startswith(f"--- {path}") and "\n+" in out and "\n-" in out
    assert path.read_text() == MESSY

    code, _, _ = run(capsys, "fmt", str(path))
    assert code == 0
    formatted = path.read_text()
    assert formatted != MESSY and "# the robot" in formatted
    assert run(capsys, "fmt", "--check", str(path))[0] == 0
    assert run(capsys, "fmt", "--diff", str(path))[1:] == ("", "")
    assert run(capsys, "fmt", "--diff", str(path))[0] == 0
    assert run(capsys, "fmt", str(path))[0] == 0
    assert path.read_text() == formatted, "fmt is not idempotent"


def test_fmt_keeps_the_model(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    before = tmp_path / "before.ram"
    before.write_text(MESSY)
    after = tmp_path / "after.ram"
    after.write_text(MESSY)
    assert run(capsys, "fmt", str(after))[0] == 0
    assert load_model(after) == load_model(before)


def test_fmt_check_passes_on_formatted_examples(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    copies = []
    for model in MODELS:
        copy = tmp_path / model.name
        copy.write_text(format_model(load_model(model)))
        copies.append(str(copy))
    assert run(capsys, "fmt", "--check", *copies)[0] == 0


def test_fmt_syntax_error_exits_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "broken.ram"
    path.write_text("robot r\nnode {\n")
    code, _, err = run(capsys, "fmt", str(path))
    assert code == 1 and "error[RAC" in err
    assert path.read_text() == "robot r\nnode {\n"


# --- export -----------------------------------------------------------------------------------


@pytest.mark.parametrize("model", MODELS, ids=lambda p: p.stem)
def test_export_json_and_ram(
    model: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, _ = run(capsys, "export", "--json", str(model))
    assert code == 0
    doc = json.loads(out)
    assert doc["format"] == "ram/1" and doc["name"] == model.stem
    assert doc == model_to_json(load_model(model))

    json_path = tmp_path / "m.json"
    json_path.write_text(out)
    code, ram_text, _ = run(capsys, "export", "--ram", str(json_path))
    assert code == 0
    assert ram_text == format_model(load_model(json_path))
    ram_path = tmp_path / "m.ram"
    ram_path.write_text(ram_text)
    assert run(capsys, "export", "--json", str(ram_path))[1] == out

    written = tmp_path / "w.json"
    wrote = f"wrote {written}\n"  # on stderr: stdout stays empty
    assert run(capsys, "export", "--json", str(model), "-o", str(written)) == (0, "", wrote)
    assert written.read_text() == out


def test_export_of_an_invalid_model_exits_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.ram"
    bad.write_text("robot r\ntopic /x\nnode n { subscribes /y }\n")
    code, out, err = run(capsys, "export", "--json", str(bad))
    assert (code, out) == (1, "")
    assert "error[RAC012]" in err
