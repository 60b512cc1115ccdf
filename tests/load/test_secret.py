"""The robot's racc secret file (rac.load.secret)."""

from __future__ import annotations

import os
import threading
from pathlib import Path

import pytest

from rac.errors import RacError
from rac.load.secret import KEY_BYTES, default_secret_path, load_secret


def test_the_first_node_makes_a_secret_only_its_user_can_read(tmp_path: Path) -> None:
    path = tmp_path / "ros" / "racc" / "secret"
    key = load_secret(path)
    assert len(key) == KEY_BYTES
    assert (path.stat().st_mode & 0o777) == 0o600
    assert (path.parent.stat().st_mode & 0o777) == 0o700
    assert load_secret(path) == key  # the same key from then on
    assert [p.name for p in path.parent.iterdir()] == ["secret"]  # no temporary left


def test_nodes_starting_together_agree_on_one_secret(tmp_path: Path) -> None:
    path = tmp_path / "secret"
    keys: list[bytes] = []
    threads = [threading.Thread(target=lambda: keys.append(load_secret(path))) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(set(keys)) == 1 and len(keys) == 8


def test_a_secret_others_can_read_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "secret"
    load_secret(path)
    path.chmod(0o644)
    with pytest.raises(RacError) as err:
        load_secret(path)
    (d,) = err.value.diagnostics
    assert d.code == "RAC150" and "other users (mode 0644)" in d.message
    assert d.hint is not None and "chmod 600" in d.hint


@pytest.mark.skipif(os.getuid() != 0, reason="changing a file's owner needs root")
def test_a_secret_of_another_user_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "secret"
    load_secret(path)
    os.chown(path, 65534, 65534)
    with pytest.raises(RacError, match="belongs to user 65534"):
        load_secret(path)


def test_a_damaged_or_missing_secret_says_what_to_do(tmp_path: Path) -> None:
    path = tmp_path / "secret"
    fd = os.open(path, os.O_WRONLY | os.O_CREAT, 0o600)
    os.write(fd, b"not hex\n")
    os.close(fd)
    with pytest.raises(RacError, match="not a racc secret"):
        load_secret(path)
    with pytest.raises(RacError, match="no racc secret here"):
        load_secret(tmp_path / "absent", create=False)
    link = tmp_path / "link"
    link.symlink_to(path)
    with pytest.raises(RacError, match="cannot read"):
        load_secret(link)


def test_the_default_place(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.delenv("RACC_SECRET_FILE", raising=False)
    monkeypatch.setenv("ROS_HOME", str(tmp_path))
    assert default_secret_path() == tmp_path / "racc" / "secret"
    monkeypatch.setenv("RACC_SECRET_FILE", str(tmp_path / "k"))
    assert default_secret_path() == tmp_path / "k"
