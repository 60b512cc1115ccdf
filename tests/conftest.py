"""Shared pytest configuration: the ``--update-goldens`` option and its fixtures."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

import pytest

TESTS_DIR = Path(__file__).resolve().parent
if str(TESTS_DIR) not in sys.path:  # so that `from goldens import assert_golden` works
    sys.path.insert(0, str(TESTS_DIR))

from goldens import assert_golden  # noqa: E402


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
