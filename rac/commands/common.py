"""Helpers the commands share: help formatting, model loading, atomic writes."""

from __future__ import annotations

import argparse
import errno
import json
import os
import shutil
import sys
import tempfile
import textwrap
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rac.errors import Diagnostic, RacError

if TYPE_CHECKING:  # the compiler loads on first use: not every command compiles a model
    from rac.ir import Model
    from rac.pipeline import Compiled
    from rac.synth.truth import GroundTruth


_RUN = "\0"  # joins a run of values: no command-line argument can hold a NUL


class CommandParser(argparse.ArgumentParser):
    """A command's parser, linear in an option given thousands of times.

    argparse looks at every remaining option string at each option it meets, which is
    quadratic: ``--obs`` given 40,000 times took 40 s.  A run of consecutive uses of an
    option registered with :meth:`batch` reaches argparse as one use of a hidden option
    holding the run's values in order; its action must split them (:func:`run_values`).
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.batched: dict[str, str] = {}  # option -> the hidden option taking a run of it
        # ``NAME:=VALUE`` words after an option (``racc run DIR --ros 2 board:=H:P``) go to
        # this list attribute, which argparse's positional would not take a second time.
        self.assignments: str | None = None

    def batch(self, option: str, hidden: str) -> None:
        self.batched[option] = hidden

    def parse_known_args(  # type: ignore[override]
        self, args: Any = None, namespace: Any = None
    ) -> tuple[argparse.Namespace, list[str]]:
        if args is not None and self.batched:
            args = batched_runs(list(args), self.batched)
        parsed, extra = super().parse_known_args(args, namespace)
        if extra and self.assignments is not None:
            words = [w for w in extra if ":=" in w and not w.startswith("-")]
            setattr(parsed, self.assignments, [*getattr(parsed, self.assignments), *words])
            extra = [w for w in extra if w not in words]
        if extra:
            # Left to the top-level parser, the error would show `racc`'s usage, not the
            # command's: the user needs to see the options of the command they typed.
            self.error(f"unrecognized arguments: {' '.join(extra)}")
        return parsed, extra


def batched_runs(args: list[str], batched: Mapping[str, str]) -> list[str]:
    """``args`` with each run of two or more ``OPT VALUE`` (or ``OPT=VALUE``) of one batched
    option replaced by ``HIDDEN V1<NUL>V2…``; anything unusual is left to argparse as is."""
    out: list[str] = []
    i = 0
    while i < len(args):
        option, value, width = _batchable(args, i, batched)
        if option is None:
            if args[i] == "--":  # the rest is positional
                out.extend(args[i:])
                break
            out.append(args[i])
            i += 1
            continue
        values = [value]
        j = i + width
        while True:
            other, more, step = _batchable(args, j, batched)
            if other != option:
                break
            values.append(more)
            j += step
        if len(values) == 1:
            out.extend(args[i:j])
        else:
            out.extend((batched[option], _RUN.join(values)))
        i = j
    return out


def _batchable(args: list[str], i: int, batched: Mapping[str, str]) -> tuple[str | None, str, int]:
    """(option, value, how many arguments) when ``args[i]`` starts a batchable use."""
    if i >= len(args):
        return None, "", 0
    arg = args[i]
    if arg in batched and i + 1 < len(args):
        value, width = args[i + 1], 2
    elif "=" in arg and arg.split("=", 1)[0] in batched:
        arg, value = arg.split("=", 1)
        width = 1
    else:
        return None, "", 0
    if value.startswith("-") or _RUN in value:
        return None, "", 0  # argparse's own rules (and errors) for these
    return arg, value, width


def run_values(value: str) -> list[str]:
    """The values of a batched run (:class:`CommandParser`)."""
    return value.split(_RUN)


def add_command(
    sub: Any, name: str, summary: str, description: str, examples: str
) -> argparse.ArgumentParser:
    """A subcommand parser whose help ends with worked examples."""
    parser: argparse.ArgumentParser = sub.add_parser(
        name,
        help=summary,
        description=description,
        epilog="examples:\n" + examples,
        formatter_class=HelpFormatter,
    )
    return parser


class HelpFormatter(argparse.HelpFormatter):
    """Descriptions wrapped to the terminal, paragraph by paragraph; indented lines (the
    examples, lists) kept as written."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        out = []
        for paragraph in text.split("\n\n"):
            lines = paragraph.splitlines()
            if any(line[:1].isspace() for line in lines) or paragraph.startswith("examples:"):
                out.append("\n".join(indent + line for line in lines))
            else:
                out.append(
                    textwrap.fill(
                        " ".join(lines), width, initial_indent=indent, subsequent_indent=indent
                    )
                )
        return "\n\n".join(out)


def count(n: int, noun: str) -> str:
    """``1 node``, ``2 nodes``; ``hardware`` has no plural."""
    if n == 1 or noun in ("hardware", "Hz"):
        return f"{n} {noun}"
    return (
        f"{n} {noun[:-1]}ies" if noun.endswith("y") and noun[-2] not in "aeiou" else f"{n} {noun}s"
    )


def print_warnings(diagnostics: tuple[Diagnostic, ...], source: str | None) -> None:
    """The warnings, capped like errors (:meth:`RacError.render`)."""
    warnings = [d for d in diagnostics if not d.is_error]
    if warnings:
        print(RacError(warnings, source).render(), file=sys.stderr)


def checked_truth(
    truth: GroundTruth, models: Sequence[Model], *, quiet: bool, robot: bool = True
) -> None:
    """Stop (RAC086) when a culprit of the ground truth is in none of ``models``: every
    diagnosis would be scored wrong.  The RAC107 warning (another robot) unless ``quiet``."""
    from rac.synth.truth import check_truth

    found = check_truth(truth, models, robot)
    if any(d.is_error for d in found):
        raise RacError(found, truth.source)
    if found and not quiet:
        print_warnings(tuple(found), truth.source)


def load_and_compile(path: str, *, quiet: bool = False) -> Compiled:
    """Load a .ram/.json model, validate and derive; warnings go to stderr."""
    from rac.loader import load_model
    from rac.pipeline import WARNINGS_LOCATED_UP_TO, compile_model, located

    model = load_model(path)
    compiled = compile_model(model)
    if not quiet and compiled.warnings:
        shown = located(model, compiled.warnings, up_to=WARNINGS_LOCATED_UP_TO)
        print_warnings(shown, model.source)
    return compiled


def load_checked(path: str) -> Model:
    return load_and_compile(path, quiet=True).model


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


def json_text(doc: Any, args: argparse.Namespace) -> str:
    """A command's ``--json`` output: one line, or indented with ``--pretty`` (the shapes are
    docs/spec.md's; whitespace is not part of them)."""
    return json.dumps(doc, indent=2 if getattr(args, "pretty", False) else None)


def add_ros_option(parser: argparse.ArgumentParser) -> None:
    """``--ros 1|2``: the transport of a live command (default: from the environment)."""
    parser.add_argument(
        "--ros",
        type=int,
        choices=(1, 2),
        help="ROS 1 (rospy) or ROS 2 (rclpy); default: ROS_VERSION, else ROS 2 when rclpy "
        "is importable and rospy is not, else ROS 1",
    )


def ros_version(args: argparse.Namespace) -> int:
    """The transport ``--ros`` names, or the one the environment has (see add_ros_option)."""
    import importlib.util

    chosen = getattr(args, "ros", None)
    if chosen in (1, 2):
        return int(chosen)
    env = os.environ.get("ROS_VERSION", "").strip()
    if env in ("1", "2"):
        return int(env)

    def importable(module: str) -> bool:
        try:
            return importlib.util.find_spec(module) is not None
        except (ImportError, ValueError):
            return False

    return 2 if importable("rclpy") and not importable("rospy") else 1
