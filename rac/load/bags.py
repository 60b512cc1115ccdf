"""Recordings: a ROS 1 ``.bag`` file or a ROS 2 bag directory (sqlite3 or mcap), read with
rosbags into the arrays of :mod:`rac.learn.recording` (what learning and replay take)."""

from __future__ import annotations

import math
import struct
import sys
from collections.abc import Iterator, Sequence
from pathlib import Path

import apsw
import numpy as np
from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.interfaces import Connection
from rosbags.rosbag1 import Reader as Reader1
from rosbags.rosbag1 import ReaderError as Rosbag1Error
from rosbags.rosbag2 import ReaderError as Rosbag2Error
from rosbags.serde import SerdeError
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.base import TypesysError
from rosbags.typesys.store import Typestore

from rac.errors import Diagnostic, RacError
from rac.learn.fields import FieldSelector, layout_of, with_angles
from rac.learn.raw import row_reader
from rac.learn.recording import WRAPPING, Recording, Run, TopicData, merge_runs
from rac.learn.stamps import stamp_reader
from rac.limits import check_yaml_limits
from rac.load.files import read_text
from rac.load.kinds import RECORDING, check_kind
from rac.parallel import run_all

# What a damaged bag raises while its messages are read: rosbags' own errors, the
# struct/index/assert failures of its parsers meeting corrupt bytes, SQLite's (through apsw)
# on a damaged database page met while iterating, and OverflowError on a damaged MCAP length
# too large for a read.
_DAMAGED = (
    AnyReaderError,
    Rosbag1Error,
    Rosbag2Error,
    SerdeError,
    TypesysError,
    OSError,
    ValueError,
    KeyError,
    IndexError,
    EOFError,
    AssertionError,
    OverflowError,
    struct.error,
    apsw.Error,
)


def model_type_name(msgtype: str) -> str:
    """``sensor_msgs/msg/Imu`` -> ``sensor_msgs/Imu``, the spelling models use."""
    return msgtype.replace("/msg/", "/")


# The longest run racc reads (a week).  Replay steps the observers through it in 0.1 s
# steps, and learning takes its rates and windows from it: one message stamped 1970 in a bag
# of today would make that fifty years.
MAX_SPAN_S = 7 * 86400.0


def far_off_stamp(path: str, span: float) -> RacError:
    """RAC080 for a recording whose time stamps span more than :data:`MAX_SPAN_S`."""
    message = (
        f"{path}: its messages span {span / 86400:,.0f} days "
        f"(at most {MAX_SPAN_S / 86400:g}): a time stamp is far off"
    )
    hint = "was simulated time mixed with wall-clock time while recording?"
    return RacError([Diagnostic("RAC080", message, hint=hint)])


def _fail(path: str, why: str) -> RacError:
    hint = "a RUN is a ROS 1 .bag file or a ROS 2 bag directory (sqlite3 or mcap)"
    return RacError([Diagnostic("RAC080", f"{path}: cannot read the recording: {why}", hint=hint)])


def read_run(
    path: str | Path, selector: FieldSelector, topics: frozenset[str] | None = None
) -> Run:
    """Every topic of one recording (or only ``topics``), with the fields ``selector`` wants."""
    p = Path(path)
    check_kind(path, RECORDING, "RAC080")
    try:
        if not p.exists():  # inside: a name too long for the file system raises here
            raise _fail(str(path), "no such file or directory")
        if p.is_dir():
            _check_metadata(p, str(path))
        # Bags written without message definitions (older ROS 2) fall back to the standard types.
        store = get_typestore(Stores.ROS2_HUMBLE if p.is_dir() else Stores.ROS1_NOETIC)
        try:
            with AnyReader([p], default_typestore=store) as reader:
                return _read(reader, str(path), selector, topics)
        except (TypesysError, AnyReaderError) as err:
            # Old ROS 1 bags define `Header` as roslib/Header, which the definitions the bag
            # carries then lack: decode with Noetic's own definitions instead.
            if p.is_dir() or "is unknown" not in str(err):
                raise
            with Reader1(p) as bag:
                return _read(_WithTypestore(bag, store), str(path), selector, topics)
    except _DAMAGED as err:
        raise _fail(str(path), _damage(err, p)) from None
    except MemoryError:
        # A damaged length field (an MCAP record's, say) asks the reader for terabytes.
        why = "reading it ran out of memory: a length in it is damaged, or the run is too large"
        raise _fail(str(path), why) from None
    except Exception as err:
        # Any other error the reader library's own code raised on the file's bytes (a
        # TypeError from ord() of an MCAP read cut short): the file, not racc, is at fault.
        # One raised in racc's code is a bug and stays an internal error.
        if not _raised_by_reader(err):
            raise
        why = f"damaged ({type(err).__name__}: {err})"
        raise _fail(str(path), f"{_storage_files(p)}: {why}" if p.is_dir() else why) from None


# rosbags is a namespace package (no __file__): its folder is that of one of its modules
_READER_PACKAGE = Path(sys.modules[AnyReader.__module__].__file__ or "").parent.parent


def _raised_by_reader(err: BaseException) -> bool:
    """Was ``err`` raised in the reader library (rosbags), its innermost Python frame there?"""
    tb = err.__traceback__
    if tb is None:
        return False
    while tb.tb_next is not None:
        tb = tb.tb_next
    return Path(tb.tb_frame.f_code.co_filename).is_relative_to(_READER_PACKAGE)


def _damage(err: Exception, path: Path) -> str:
    """What a damaged recording's error says, for a user: the storage file it was met in."""
    why = str(err) or f"damaged ({type(err).__name__})"
    if isinstance(err, KeyError | IndexError | AssertionError) and str(err):
        # Their text alone is a bare key or index ("'sensor_msgs/msg/Imu'").
        why = f"damaged or inconsistent ({type(err).__name__}: {err})"
    elif isinstance(err, UnicodeDecodeError):  # Python's "'utf-8' codec can't decode ..."
        byte = err.object[err.start : err.start + 1].hex() or "?"
        why = f"damaged: a name or text in it is not UTF-8 (byte 0x{byte})"
    elif isinstance(err, OverflowError):  # "cannot fit 'int' into an index-sized integer"
        why = f"a length in it is damaged (OverflowError: {err})"
    elif isinstance(err, apsw.Error):
        why = f"its SQLite database is damaged ({err})"
    if isinstance(err, OverflowError | apsw.Error) and path.is_dir():
        why = f"{_storage_files(path)}: {why}"
    return why


def _storage_files(directory: Path) -> str:
    """The storage files of a ROS 2 bag directory, by name."""
    try:
        names = [f.name for f in sorted(directory.iterdir()) if f.suffix in (".db3", ".mcap")]
    except OSError:
        names = []
    return ", ".join(names) or "its storage file"


def _check_metadata(directory: Path, path: str) -> None:
    """A ROS 2 bag's metadata.yaml within racc's YAML limits, before rosbags' YAML reader
    (ruamel.yaml, recursive) reads it: nested 600 deep it ran out of stack.  RAC080 at the
    line of the metadata.yaml; one that is not YAML is left to rosbags to report."""
    metadata = directory / "metadata.yaml"
    if not metadata.is_file():
        return
    try:
        check_yaml_limits(read_text(metadata, "RAC080"), str(metadata))
    except RacError as err:
        found = err.diagnostics[0]
        message = f"{path}: cannot read the recording: its metadata.yaml: {found.message}"
        hint = "the bag's metadata.yaml is damaged: 'ros2 bag reindex' writes it anew"
        raise RacError([Diagnostic("RAC080", message, found.span, hint=hint)], err.source) from None


class _WithTypestore:
    """A ROS 1 bag read through a fixed typestore, its own message definitions ignored
    (the part of AnyReader's interface :func:`_read` uses)."""

    is2 = False

    def __init__(self, bag: Reader1, typestore: Typestore) -> None:
        self.bag = bag
        self.typestore = typestore
        self.connections = bag.connections

    def messages(
        self, connections: Sequence[Connection]
    ) -> Iterator[tuple[Connection, int, bytes]]:
        return self.bag.messages(connections=connections)

    def deserialize(self, rawdata: bytes, typ: str) -> object:
        return self.typestore.deserialize_ros1(rawdata, typ)


def _read(
    reader: AnyReader | _WithTypestore,
    path: str,
    selector: FieldSelector,
    only: frozenset[str] | None,
) -> Run:
    fielddefs = reader.typestore.fielddefs
    connections = [c for c in reader.connections if only is None or c.topic in only]
    types: dict[str, str] = {}
    publishers: dict[str, set[str]] = {}
    for conn in connections:
        if types.setdefault(conn.topic, conn.msgtype) != conn.msgtype:
            raise _fail(path, f"topic {conn.topic} is recorded with two types")
        callerid = getattr(conn.ext, "callerid", None)
        names = publishers.setdefault(conn.topic, set())
        if callerid:
            names.add(callerid.removeprefix("/"))
    layouts = {t: layout_of(fielddefs, m, t, selector) for t, m in types.items()}
    # Each message's row comes straight from its bytes where the type allows (rac.learn.raw).
    cdr = reader.is2
    extract = {
        t: row_reader(reader.typestore, types[t], lay, cdr=cdr, deserialize=reader.deserialize)
        for t, lay in layouts.items()
        if not lay.empty
    }
    # The publisher's header stamp of each message, where its type begins with a header.
    headers = {t: stamp_reader(fielddefs, m, cdr=cdr) for t, m in types.items()}
    header_stamps: dict[str, list[float]] = {t: [] for t, r in headers.items() if r is not None}
    stamps: dict[str, list[int]] = {t: [] for t in types}
    rows: dict[str, list[tuple[float, ...]]] = {t: [] for t in extract}
    count = 0
    # rosbags reads every connection when given none: none wanted means nothing to read.
    for conn, stamp, raw in reader.messages(connections=connections) if connections else ():
        count += 1
        if not isinstance(raw, bytes | memoryview | bytearray):
            # a damaged SQLite row: its data column reads NULL or text, not a blob
            why = f"message {count} on {conn.topic} is not bytes: the database is damaged"
            raise _fail(path, why)
        stamps[conn.topic].append(stamp)
        read_stamp = headers.get(conn.topic)
        if read_stamp is not None:
            found = read_stamp(raw)
            header_stamps[conn.topic].append(math.nan if found is None else found)
        get = extract.get(conn.topic)
        if get is not None:
            rows[conn.topic].append(get(raw))
    data = []
    for name in sorted(types):
        if not stamps[name]:
            continue
        times = np.asarray(stamps[name], dtype=np.float64) * 1e-9
        lay = layouts[name]
        matrix = np.asarray(rows.get(name, []), dtype=np.float64).reshape(len(times), -1)
        values = np.ascontiguousarray(with_angles(lay, matrix).T)
        for i, f in enumerate(lay.fields):
            if f in WRAPPING and f in lay.euler and values.shape[1] > 1:
                values[i] = np.unwrap(values[i])
        column = header_stamps.get(name)
        data.append(
            TopicData(
                name=name,
                msg_type=model_type_name(types[name]),
                publishers=tuple(sorted(publishers[name])),
                times=times,
                segments=np.zeros(times.size, dtype=np.int64),
                fields=lay.fields,
                values=values,
                stamps=None if column is None else np.asarray(column, dtype=np.float64),
            )
        )
    if not data:
        raise _fail(path, "it holds no messages")
    start = min(float(t.times[0]) for t in data)
    end = max(float(t.times[-1]) for t in data)
    # The recording's own span, every topic's messages (read or not) included: replay
    # judges up to its end, and times count from its start.
    span = _span(reader)
    if span is not None and span[1] - span[0] <= MAX_SPAN_S:
        start, end = min(start, span[0]), max(end, span[1])
    if end - start > MAX_SPAN_S:
        raise far_off_stamp(path, end - start)
    ros_version = 2 if reader.is2 else 1
    skipped = tuple(sorted({c.topic for c in reader.connections} - set(types)))
    return Run(path, ros_version, start, end, tuple(data), count, skipped)


def _span(reader: AnyReader | _WithTypestore) -> tuple[float, float] | None:
    """The first and last message time of the whole recording (every topic), seconds."""
    bag = reader.bag if isinstance(reader, _WithTypestore) else reader
    try:
        first, last = int(bag.start_time), int(bag.end_time)
    except Exception:  # an index without times: the messages read decide
        return None
    if last <= first:
        return None
    # rosbags gives the end as one past the last message's time (ns)
    return first * 1e-9, (last - 1) * 1e-9


def read_recording(
    paths: Sequence[str | Path],
    selector: FieldSelector,
    topics: frozenset[str] | None = None,
    jobs: int = 1,
) -> Recording:
    """Several recordings as one training set (Algorithm 19), each read on its own, on up
    to ``jobs`` processes."""

    def one(path: str | Path) -> Run:
        return read_run(path, selector, topics)

    return merge_runs(run_all(one, list(paths), jobs))
