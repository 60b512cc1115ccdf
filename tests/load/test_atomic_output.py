"""``racc compile`` output is all-or-nothing: the directory is swapped whole, or left alone.

Real failures where this machine allows them (chattr +i, a small tmpfs, a directory in place of
a file), a simulated one (a rename failing mid-swap) where no file system produces it on demand.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

from rac.cli import main

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = ROOT / "models" / "tedusar.ram"
PIONEER = ROOT / "models" / "pioneer.ram"


def _snapshot(directory: Path) -> dict[str, tuple[bytes, int]]:
    return {
        str(p.relative_to(directory)): (p.read_bytes(), p.stat().st_mtime_ns)
        for p in sorted(directory.rglob("*"))
        if p.is_file()
    }


def _compile(model: Path, out: Path) -> int:
    return main(["compile", str(model), "-o", str(out), "-q", "--no-svg"])


def _chattr(flag: str, path: Path) -> bool:
    if shutil.which("chattr") is None:
        return False
    done = subprocess.run(["chattr", flag, str(path)], capture_output=True, check=False)
    return done.returncode == 0


@pytest.fixture
def built(tmp_path: Path) -> Iterator[Path]:
    out = tmp_path / "out"
    assert _compile(TEDUSAR, out) == 0
    (out / "CMakeLists.txt").write_text("mine\n")  # a file racc does not write
    yield out


def _assert_untouched(out: Path, before: dict[str, tuple[bytes, int]], parent: Path) -> None:
    assert _snapshot(out) == before
    leftovers = [p.name for p in parent.iterdir() if p.name.startswith(".racc-")]
    assert leftovers == [], "a staging directory was left behind"


def test_recompile_replaces_every_file_and_keeps_foreign_ones(
    built: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (built / "architecture.svg").write_text("stale")  # racc's name: removed, not carried over
    assert _compile(PIONEER, built) == 0
    assert (built / "CMakeLists.txt").read_text() == "mine\n"
    assert not (built / "architecture.svg").exists()
    assert "pioneer" in (built / "model.yaml").read_text() or (built / "model.yaml").exists()
    assert [p.name for p in built.parent.iterdir() if p.name.startswith(".racc-")] == []
    capsys.readouterr()


def test_immutable_output_file_leaves_everything_untouched(
    built: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = built / "model.yaml"
    if not _chattr("+i", target):
        pytest.skip("chattr +i is not possible here (needs root and ext2/3/4, xfs or btrfs)")
    try:
        before = _snapshot(built)
        assert _compile(PIONEER, built) == 1
        assert "error[RAC004]" in capsys.readouterr().err
        _assert_untouched(built, before, built.parent)
    finally:
        _chattr("-i", target)


def test_immutable_foreign_file_leaves_everything_untouched(
    built: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = built / "CMakeLists.txt"
    if not _chattr("+i", target):
        pytest.skip("chattr +i is not possible here (needs root and ext2/3/4, xfs or btrfs)")
    try:
        before = _snapshot(built)
        assert _compile(PIONEER, built) == 1
        assert "error[RAC004]" in capsys.readouterr().err
        _assert_untouched(built, before, built.parent)
    finally:
        _chattr("-i", target)


def test_directory_in_place_of_an_output_file(
    built: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (built / "model.yaml").unlink()
    (built / "model.yaml").mkdir()
    (built / "model.yaml" / "keep.txt").write_text("user data\n")
    before = _snapshot(built)
    assert _compile(PIONEER, built) == 1
    err = capsys.readouterr().err
    assert "error[RAC004]" in err and "model.yaml" in err
    _assert_untouched(built, before, built.parent)


def test_unwritable_parent_directory(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    parent = tmp_path / "ro"
    out = parent / "out"
    assert _compile(TEDUSAR, out) == 0
    before = _snapshot(out)
    # Root ignores permission bits, so use the immutable flag there; chmod otherwise.
    if os.geteuid() == 0:
        if not _chattr("+i", parent):
            pytest.skip("running as root, and chattr +i is not possible here")
    else:
        parent.chmod(0o555)
    try:
        assert _compile(PIONEER, out) == 1
        assert "error[RAC004]" in capsys.readouterr().err
        assert _snapshot(out) == before
    finally:
        if os.geteuid() == 0:
            _chattr("-i", parent)
        parent.chmod(0o755)
    assert sorted(p.name for p in parent.iterdir()) == ["out"]


def test_full_disk_leaves_everything_untouched(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mount = tmp_path / "small"
    mount.mkdir()
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs", str(mount)],
        capture_output=True,
        check=False,
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here: {done.stderr.decode().strip()}")
    try:
        out = mount / "out"
        assert _compile(PIONEER, out) == 0
        before = _snapshot(out)
        # Fill the disk: the next compile cannot stage its files.
        with (mount / "filler").open("wb", buffering=0) as filler:
            try:
                while True:
                    filler.write(b"\0" * 4096)
            except OSError:
                pass
        assert _compile(TEDUSAR, out) == 1
        err = capsys.readouterr().err
        assert "error[RAC004]" in err and "No space left on device" in err
        _assert_untouched(out, before, mount)
    finally:
        subprocess.run(["umount", str(mount)], check=False)


def test_simulated_rename_failure_mid_swap_restores_the_old_directory(
    built: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Simulated: the second rename (new directory in) fails after the old one moved aside."""
    before = _snapshot(built)
    real_rename = os.rename
    calls: list[str] = []

    def flaky(src: str | os.PathLike[str], dst: str | os.PathLike[str]) -> None:
        calls.append(str(dst))
        if len(calls) == 2:
            raise OSError(5, "simulated I/O error")
        real_rename(src, dst)

    monkeypatch.setattr(os, "rename", flaky)
    assert _compile(PIONEER, built) == 1
    monkeypatch.undo()
    assert "simulated I/O error" in capsys.readouterr().err
    _assert_untouched(built, before, built.parent)
