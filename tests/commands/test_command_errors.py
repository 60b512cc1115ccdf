"""Error messages of commands (not of models) as goldens: ``tests/errors/commands/``.

Each ``NAME.args`` holds one ``racc`` command line, run from the repository's root; its
``.txt`` holds what racc prints on standard error and the exit code.  The codes in NAME are
the codes the command must report.  ``pytest --update-goldens`` rewrites the ``.txt`` files.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from goldens import assert_golden

from rac.cli import main
from rac.errors import CODES

ROOT = Path(__file__).resolve().parents[2]
CASES = sorted((ROOT / "tests" / "errors" / "commands").glob("*.args"))


def test_cases_name_known_codes() -> None:
    for case in CASES:
        codes = re.findall(r"RAC\d{3}", case.stem)
        assert codes and set(codes) <= set(CODES), case.name


@pytest.mark.parametrize("case", CASES, ids=lambda p: p.stem)
def test_command_error_golden(
    case: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    update_goldens: bool,
) -> None:
    monkeypatch.chdir(ROOT)
    monkeypatch.delenv("ROS_VERSION", raising=False)
    code = main(shlex.split(case.read_text(encoding="utf-8")))
    err = capsys.readouterr().err
    reported = set(re.findall(r"error\[(RAC\d{3})\]", err))
    assert reported == set(re.findall(r"RAC\d{3}", case.stem)), err
    assert code == 1
    assert_golden(case.with_suffix(".txt"), f"{err}exit {code}\n", update_goldens)
