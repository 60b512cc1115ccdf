"""The robot's racc secret: the key every racc process seals its messages with.

A file of 64 hexadecimal digits (32 random bytes) that only its owner may read, like an ssh
key: ``--secret FILE``, else ``$RACC_SECRET_FILE``, else ``$ROS_HOME/racc/secret``, else
``~/.ros/racc/secret``.  The first racc process of a robot that finds no such file makes
one (its directory 0700, the file 0600), so that a robot on one computer needs nothing
done; every other computer of the robot needs a copy of that same file, and a process whose
key differs has its messages refused (and says so).  A file that others can read, or that
belongs to another user, is refused (RAC150): a key others can read proves nothing.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import stat
from pathlib import Path

from rac.errors import Diagnostic, RacError

ENV = "RACC_SECRET_FILE"
KEY_BYTES = 32


def default_secret_path() -> Path:
    if os.environ.get(ENV):
        return Path(os.environ[ENV])
    home = os.environ.get("ROS_HOME") or str(Path.home() / ".ros")
    return Path(home) / "racc" / "secret"


def _error(path: Path, message: str, hint: str) -> RacError:
    return RacError([Diagnostic("RAC150", f"{path}: {message}", hint=hint)])


def load_secret(path: str | Path | None = None, *, create: bool = True) -> bytes:
    """The key in ``path`` (the default above when None), made first if missing and
    ``create``."""
    where = Path(path) if path else default_secret_path()
    if create and not where.exists():
        _create(where)
    try:
        fd = os.open(where, os.O_RDONLY | os.O_NOFOLLOW)
    except FileNotFoundError:
        raise _error(
            where,
            "no racc secret here",
            "copy the robot's secret file here (it is made by the first racc node of the "
            "robot), or give its path with --secret",
        ) from None
    except OSError as err:
        raise _error(where, f"cannot read the racc secret: {err.strerror}", _MODE_HINT) from None
    with os.fdopen(fd, "rb") as handle:
        info = os.fstat(handle.fileno())
        if not stat.S_ISREG(info.st_mode):
            raise _error(where, "the racc secret is not a regular file", _MODE_HINT)
        if info.st_uid != os.getuid():
            raise _error(
                where,
                f"the racc secret belongs to user {info.st_uid}, not to this user ({os.getuid()})",
                "run racc as the robot's user, or copy the secret into a file of your own",
            )
        if info.st_mode & 0o077:
            mode = stat.S_IMODE(info.st_mode)
            raise _error(
                where, f"the racc secret can be read by other users (mode {mode:04o})", _CHMOD
            )
        text = handle.read(4 * KEY_BYTES).decode("ascii", "replace").strip()
    try:
        key = bytes.fromhex(text)
    except ValueError:
        key = b""
    if len(key) != KEY_BYTES:
        raise _error(
            where,
            f"not a racc secret ({2 * KEY_BYTES} hexadecimal digits expected)",
            f"remove it to have a new one made, or copy the robot's secret over it ({where})",
        )
    return key


_MODE_HINT = "make it a file of your own that only you can read: chmod 600 FILE"
_CHMOD = "make it readable by you alone: chmod 600 FILE (a key others can read proves nothing)"


def _create(where: Path) -> None:
    """Write a new key, atomically: when two racc nodes start together, both read the one
    that won (a link fails where a file exists)."""
    try:
        where.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        fd, tmp = _temporary(where.parent)
        try:
            with os.fdopen(fd, "w") as out:
                out.write(secrets.token_hex(KEY_BYTES) + "\n")
            with contextlib.suppress(FileExistsError):
                os.link(tmp, where)
        finally:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
    except OSError as err:
        raise _error(
            where, f"cannot make a racc secret: {err.strerror}", "give a writable --secret path"
        ) from None


def _temporary(folder: Path) -> tuple[int, str]:
    for _ in range(100):
        name = folder / f".secret-{secrets.token_hex(6)}"
        try:
            return os.open(name, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600), str(name)
        except FileExistsError:
            continue
    raise FileExistsError(str(folder))
