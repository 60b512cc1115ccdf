"""Shared pytest configuration: the ``--update-goldens`` option and its fixtures, and the
``slow`` marker the README's quick run leaves out."""

from __future__ import annotations

import signal
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import pytest

TESTS_DIR = Path(__file__).resolve().parent
if str(TESTS_DIR) not in sys.path:  # so that `from goldens import assert_golden` works
    sys.path.insert(0, str(TESTS_DIR))

from goldens import assert_golden  # noqa: E402

# The README's test command (`pytest`, install included) must finish in under 5 minutes on
# 2 cores: tests marked ``slow`` are deselected unless a marker expression is given (`pytest
# -m slow` runs them, `pytest -m "slow or not slow"` everything; .ci/run runs them in a stage
# of their own) or a test is named by its id (`pytest tests/x.py::test_y`).  A quick-run test
# that takes longer than QUICK_TEST_S is listed at the end of the run, to be marked slow.
SLOW = "slow"
QUICK_TEST_S = 10.0


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers",
        f"{SLOW}: a test of more than a few seconds; the quick run (`pytest`) leaves it out, "
        "`pytest -m slow` runs it (and .ci/run does)",
    )
    named = any("::" in str(arg) for arg in config.args)
    if not config.option.markexpr and not named:  # xdist workers read the same arguments
        config.option.markexpr = f"not {SLOW}"
    config.pluginmanager.register(QuickRun(config), "racc-quick-run")


class QuickRun:
    """What the run left out and why, and the quick-run tests that took long: printed at
    the end (xdist's summary does not count deselected tests)."""

    def __init__(self, config: pytest.Config) -> None:
        self.config = config
        self.quick = config.option.markexpr == f"not {SLOW}"
        self.deselected: dict[str, int] = {}
        self.long: list[tuple[float, str]] = []
        self.worker = hasattr(config, "workerinput")

    def pytest_report_header(self) -> str | None:
        if self.quick:
            return "quick run: tests marked slow are deselected (`pytest -m slow` runs them)"
        return None

    def pytest_deselected(self, items: Sequence[pytest.Item]) -> None:
        for item in items:
            if item.get_closest_marker(SLOW) is not None:
                reason = "slow"
            elif item.path.parent.name == "live":
                reason = "live"
            else:
                reason = "other"
            self.deselected[reason] = self.deselected.get(reason, 0) + 1

    def pytest_collection_finish(self, session: pytest.Session) -> None:
        output = getattr(self.config, "workeroutput", None)
        if output is not None:  # an xdist worker: its counts go to the controller
            output["racc_deselected"] = dict(self.deselected)

    @pytest.hookimpl(optionalhook=True)
    def pytest_testnodedown(self, node: Any, error: object) -> None:
        """xdist's controller: every worker collects the same tests; keep one's counts."""
        counts = getattr(node, "workeroutput", {}).get("racc_deselected")
        if counts:
            self.deselected = dict(counts)

    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        if self.quick and report.when == "call" and report.duration > QUICK_TEST_S:
            self.long.append((report.duration, report.nodeid))

    def pytest_terminal_summary(self, terminalreporter: pytest.TerminalReporter) -> None:
        if self.worker:
            return
        parts = []
        if self.deselected.get("slow"):
            parts.append(f"{self.deselected['slow']} slow (`pytest -m slow` runs them)")
        if self.deselected.get("live"):
            parts.append(f"{self.deselected['live']} live of a ROS version not importable here")
        if self.deselected.get("other"):
            parts.append(f"{self.deselected['other']} by -k or -m")
        if parts:
            terminalreporter.write_line(f"deselected: {', '.join(parts)}")
        if self.long:
            terminalreporter.write_line(
                f"quick-run tests over {QUICK_TEST_S:g} s (mark them @pytest.mark.slow):"
            )
            for duration, nodeid in sorted(self.long, reverse=True):
                terminalreporter.write_line(f"  {duration:.1f} s {nodeid}")


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--update-goldens",
        action="store_true",
        default=False,
        help="rewrite golden files (tests/golden/, tests/errors/*.txt) from the current output",
    )


@pytest.fixture(scope="session")
def update_goldens(request: pytest.FixtureRequest) -> bool:
    """True when pytest runs with ``--update-goldens``."""
    return bool(request.config.getoption("--update-goldens"))


@pytest.fixture
def golden(update_goldens: bool) -> Callable[[Path, str], None]:
    """``golden(path, text)``: compare ``text`` with the golden at ``path`` (or rewrite it)."""

    def check(path: Path, text: str) -> None:
        assert_golden(path, text, update_goldens)

    return check


@pytest.fixture
def short_pioneer_run(tmp_path: Path) -> Path:
    """A 20 s synthetic recording of models/pioneer.ram (``racc synth``), without faults,
    with its ground truth ``r.faults.yaml`` beside it."""
    from rac.cli import main

    run = tmp_path / "r.bag"
    pioneer = Path(__file__).resolve().parent.parent / "models" / "pioneer.ram"
    assert main(["synth", str(pioneer), "-o", str(run), "--duration", "20", "-q"]) == 0
    return run


@pytest.fixture(autouse=True)
def sigint_stops_children() -> None:
    """Every process a test starts gets SIGINT as a robot's would: its default.  A process
    started with SIGINT ignored (a background job of a shell) passes that on to every
    child, and a node that ignores SIGINT neither stops politely nor ends cleanly, which
    tests of racc's stops would read as racc's fault."""
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
