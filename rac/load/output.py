"""Output files: racc writes each output directory or file atomically (staged beside it,
then moved in place), so a failure leaves the old outputs exactly as they were."""

from __future__ import annotations

import errno
import os
import shutil
import sys
import tempfile
from collections.abc import Iterable, Mapping
from pathlib import Path

from rac.errors import Diagnostic, RacError


def write_files_atomically(
    directory: Path, files: Mapping[str, str | bytes], owned: Iterable[str] = ()
) -> None:
    """Replace ``directory`` as a whole with ``files``: all of them land, or nothing changes.

    Every file is staged in a temporary directory beside the target; then the old directory
    moves aside, the new one moves in, and the old one is removed.  Entries of the old
    directory that racc does not write (neither in ``files`` nor in ``owned``, the names it
    writes at other times) are carried over into the new one: hard-linked, or copied where a
    link is impossible.  Any failure before the swap (a full disk, an unwritable or immutable
    entry, a directory where a file goes) leaves the old directory exactly as it was.
    """
    directory = resolved_path(directory)  # a name that cannot be looked up stops here
    if directory.exists() and not directory.is_dir():
        message = f"{directory}: exists and is not a directory; choose another output directory"
        raise RacError([Diagnostic("RAC004", message)])
    if _holds_cwd(directory):
        # The swap would move the working directory aside and delete it: the shell that ran
        # racc would be left in a removed directory (and `-o /` would copy the disk).
        message = f"{directory}: is the current directory or holds it, and racc replaces DIR"
        hint = "write into a directory of its own, e.g. '-o build'"
        raise RacError([Diagnostic("RAC004", message, hint=hint)])
    ours = set(files) | set(owned)
    staged: str | None = None
    try:
        directory.parent.mkdir(parents=True, exist_ok=True)
        old = directory.is_dir()
        if old:
            _check_replaceable(directory, ours)
        staged = tempfile.mkdtemp(prefix=".racc-", dir=directory.parent)
        os.chmod(staged, directory.stat().st_mode & 0o7777 if old else _default_dir_mode())
        for name, content in files.items():
            data = content.encode("utf-8") if isinstance(content, str) else content
            (Path(staged) / name).write_bytes(data)
        if old:
            _carry_over(directory, Path(staged), ours)
            aside = tempfile.mkdtemp(prefix=".racc-old-", dir=directory.parent)
            os.rename(directory, aside)  # replaces the empty placeholder
            try:
                os.rename(staged, directory)
            except OSError:
                os.rename(aside, directory)  # put the old outputs back
                raise
            staged = None
            _remove_aside(aside)
        else:
            os.rename(staged, directory)
            staged = None
    except OSError as err:
        raise RacError([Diagnostic("RAC004", f"{directory}: cannot write: {err}")]) from None
    finally:
        if staged is not None:
            shutil.rmtree(staged, ignore_errors=True)  # nothing half-written is left behind


def resolved_path(path: Path) -> Path:
    """``path`` made absolute, its links followed; RAC004 for a loop of symbolic links or a
    name too long for the file system (a bug report, exit 70, before)."""
    try:
        resolved = path.resolve()
        resolved.exists()  # ENAMETOOLONG and ELOOP show here, not as "missing"
    except (OSError, RuntimeError) as err:  # Python 3.11 raises RuntimeError on a loop
        why = err.strerror if isinstance(err, OSError) and err.strerror else str(err)
        raise RacError([Diagnostic("RAC004", f"{path}: cannot write: {why}")]) from None
    return resolved


def _holds_cwd(directory: Path) -> bool:
    """True when ``directory`` (resolved) is the working directory or one of its parents."""
    try:
        cwd = Path.cwd().resolve()
    except OSError:  # the working directory was removed: nothing to protect
        return False
    return cwd == directory or directory in cwd.parents


# FS_IOC_GETFLAGS and the immutable and append-only flags of Linux (linux/fs.h): such an
# entry cannot be removed, even by root, so the old directory could not be cleared away.
_FS_IOC_GETFLAGS = 0x80086601
_UNREMOVABLE_FLAGS = 0x10 | 0x20


def _unremovable(path: Path) -> bool:
    try:
        import fcntl

        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOFOLLOW)
    except (ImportError, OSError):
        return False  # not Linux, or not openable: the removal itself will tell
    try:
        flags = int.from_bytes(fcntl.ioctl(fd, _FS_IOC_GETFLAGS, bytes(8))[:4], sys.byteorder)
    except OSError:
        return False  # the file system has no such flags
    finally:
        os.close(fd)
    return bool(flags & _UNREMOVABLE_FLAGS)


def _check_replaceable(directory: Path, ours: set[str]) -> None:
    """Refuse (before anything is written) what the swap could not complete."""
    for name in sorted(ours):
        path = directory / name
        if path.is_symlink() or (path.exists() and not path.is_file()):
            message = f"{path}: is not a regular file, and racc writes a file there; move it away"
            raise RacError([Diagnostic("RAC004", message)])
    for root, dirs, names in os.walk(directory):
        here = Path(root)
        if not os.access(here, os.W_OK | os.X_OK) or _unremovable(here):
            raise OSError(errno.EACCES, "cannot remove entries of this directory", str(here))
        for name in [*dirs, *names]:
            path = here / name
            if not path.is_symlink() and (path.is_file() or path.is_dir()) and _unremovable(path):
                raise OSError(errno.EPERM, "an immutable or append-only entry", str(path))


def _link_or_copy(source: str, target: str) -> None:
    try:
        os.link(source, target)
    except OSError:
        shutil.copy2(source, target)


def _carry_over(old: Path, new: Path, ours: set[str]) -> None:
    """Entries racc did not write move into the new directory (links, or copies)."""
    for entry in sorted(os.listdir(old)):
        if entry in ours:
            continue
        source, target = old / entry, new / entry
        if source.is_symlink():
            os.symlink(os.readlink(source), target)
        elif source.is_dir():
            shutil.copytree(source, target, symlinks=True, copy_function=_link_or_copy)
        elif source.is_file():
            _link_or_copy(str(source), str(target))
        else:
            raise OSError(errno.EINVAL, "neither a file nor a directory; move it away", str(source))


def _remove_aside(aside: str) -> None:
    """The swap is done; failing to clear the old directory away does not undo it."""
    try:
        shutil.rmtree(aside)
    except OSError as err:
        print(f"warning: could not remove the previous outputs at {aside}: {err}", file=sys.stderr)


def _default_dir_mode() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return 0o777 & ~mask


def check_output_file(path: str | None, option: str = "-o") -> None:
    """RAC004 before a command's work when the file it is to write names a directory (it
    would fail only at the end, after minutes of learning or replay)."""
    if path is not None and Path(path).is_dir():
        message = f"{path}: is a directory; {option} takes the name of a file to write"
        raise RacError([Diagnostic("RAC004", message, hint=f"e.g. {Path(path) / 'NAME'}")])


def write_file_atomically(path: Path, content: str | bytes) -> None:
    """Replace one file atomically (a temp file beside it, then a rename)."""
    path = resolved_path(path)
    tmp: str | None = None
    try:
        if path.is_dir():
            message = f"{path}: is a directory; give a file name"
            raise RacError([Diagnostic("RAC004", message)])
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
        # mkstemp makes the file private (0600): keep the mode of the file it replaces, or
        # give a new one the usual mode (0666 less the umask), as an editor would.
        try:
            mode = path.stat().st_mode & 0o7777
        except FileNotFoundError:
            mode = 0o666 & _default_dir_mode()
        os.chmod(fd, mode)
        if isinstance(content, bytes):
            with os.fdopen(fd, "wb") as binary:
                binary.write(content)
        else:
            with os.fdopen(fd, "w", encoding="utf-8", newline="") as handle:
                handle.write(content)
        os.replace(tmp, path)
    except OSError as err:
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)  # nothing half-written is left behind
        # The reason only: the error's own file name is the temp file, which the user never named.
        why = err.strerror or str(err)
        raise RacError([Diagnostic("RAC004", f"{path}: cannot write: {why}")]) from None
