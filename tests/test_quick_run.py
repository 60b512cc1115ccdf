"""The README's test command is a quick run (issue 38): tests marked ``slow`` are deselected,
counted at the end of the run (also under pytest-xdist, whose summary counts no deselected
test), and run by ``pytest -m slow``; a test named by its id runs whatever its marker."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent

EXAMPLE = """
import time

import pytest


def test_quick() -> None:
    pass


@pytest.mark.slow
def test_slow() -> None:
    pass


def test_long_but_unmarked() -> None:
    time.sleep(float(__import__("os").environ.get("RACC_TEST_SLEEP", "0")))
"""


def _pytest(folder: Path, *args: str, sleep: float = 0.0) -> str:
    env = {"RACC_TEST_SLEEP": str(sleep), "PATH": "/usr/bin:/bin"}
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-p", "no:randomly", *args],
        cwd=folder,
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    return done.stdout + done.stderr


@pytest.fixture
def suite(tmp_path: Path) -> Path:
    """A suite with this repository's conftest and one quick, one slow test."""
    for helper in ("conftest.py", "goldens.py"):
        shutil.copy(TESTS / helper, tmp_path / helper)
    (tmp_path / "test_example.py").write_text(EXAMPLE, encoding="utf-8")
    return tmp_path


@pytest.mark.parametrize("workers", ["0", pytest.param("2", marks=pytest.mark.slow)])
def test_the_quick_run_leaves_the_slow_tests_out_and_says_so(suite: Path, workers: str) -> None:
    out = _pytest(suite, "-n", workers)
    assert "2 passed" in out, out
    assert "deselected: 1 slow (`pytest -m slow` runs them)" in out
    assert "quick run: tests marked slow are deselected" in out


@pytest.mark.slow
def test_pytest_m_slow_runs_only_them_and_a_named_test_runs_anyway(suite: Path) -> None:
    out = _pytest(suite, "-n", "0", "-m", "slow", "-v")
    assert "test_example.py::test_slow PASSED" in out and "1 passed" in out, out
    out = _pytest(suite, "-n", "0", "-m", "slow or not slow")
    assert "3 passed" in out, out
    out = _pytest(suite, "-n", "0", "test_example.py::test_slow", "-v")
    assert "test_example.py::test_slow PASSED" in out, out


def test_a_long_unmarked_test_is_named_at_the_end(
    suite: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    conftest = suite / "conftest.py"
    conftest.write_text(
        conftest.read_text(encoding="utf-8").replace("QUICK_TEST_S = 10.0", "QUICK_TEST_S = 0.2"),
        encoding="utf-8",
    )
    out = _pytest(suite, "-n", "0", sleep=0.5)
    assert "quick-run tests over 0.2 s (mark them @pytest.mark.slow):" in out, out
    assert "test_example.py::test_long_but_unmarked" in out
