"""Golden files: compare generated text with a checked-in file, or rewrite it.

Import it from any test (``tests/`` is on ``sys.path`` through ``conftest.py``)::

    from goldens import assert_golden

    def test_thing(update_goldens):
        assert_golden(GOLDEN_DIR / "thing.txt", render(), update_goldens)

``pytest --update-goldens`` rewrites every golden a test compares with, then the test passes.
"""

from __future__ import annotations

import difflib
from pathlib import Path

import pytest

UPDATE_HINT = "run `pytest --update-goldens` to (re)generate it, then review the diff"


def assert_golden(path: Path, text: str, update: bool) -> None:
    """Fail unless ``path`` holds exactly ``text``; with ``update``, write ``text`` there first."""
    path = Path(path)
    if update:
        if not path.exists() or path.read_bytes() != text.encode("utf-8"):
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(text.encode("utf-8"))
        return
    if not path.exists():
        pytest.fail(f"golden file {path} is missing: {UPDATE_HINT}", pytrace=False)
    expected = path.read_bytes().decode("utf-8")
    if expected != text:
        diff = "".join(
            difflib.unified_diff(
                expected.splitlines(keepends=True),
                text.splitlines(keepends=True),
                fromfile=f"{path} (golden)",
                tofile=f"{path} (generated)",
                n=2,
            )
        )
        if len(diff) > 6000:
            diff = diff[:6000] + "\n... (diff cut)\n"
        pytest.fail(f"{path} differs from its golden; {UPDATE_HINT}\n{diff}", pytrace=False)
