"""``racc diagram --live``: one snapshot of the running robot's ``/diagnosis`` and
``/observations`` (both latched by racc's runtime), read through rospy or rclpy."""

from __future__ import annotations

import argparse
import os
import threading
import time
from typing import TYPE_CHECKING, Any

from rac.commands.common import ros_version
from rac.commands.reports import diagnosis_title
from rac.errors import Diagnostic, RacError
from rac.runtime.status import DIAGNOSIS, OBSERVATIONS, Row, row_diagnosis, row_verdict

if TYPE_CHECKING:
    from rac.pipeline import Compiled
    from rac.targets.coverage import Health

# After /diagnosis arrives, observations still on their way are given this long.
SETTLE_S = 0.5


class _Snapshot:
    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.diagnosis: list[Row] | None = None
        self.observations: dict[Any, bool] = {}

    def on_diagnosis(self, rows: list[Row]) -> None:
        with self.lock:
            self.diagnosis = rows

    def on_observations(self, rows: list[Row]) -> None:
        now = time.time()
        with self.lock:
            for row in rows:
                verdict = row_verdict(row, now)
                if verdict is not None:
                    self.observations[verdict.atom] = verdict.positive


def _bus(version: int) -> tuple[Any, Any]:
    """(the bus, a closer) of a short-lived node named racc_diagram_PID."""
    name = f"racc_diagram_{os.getpid()}"
    if version == 1:
        from rac.ros1.common import Ros1Bus, check_master

        check_master()
        return Ros1Bus(name), lambda: None
    from rac.ros2.common import Session

    session = Session(name)
    return session, session.close


def live_health(args: argparse.Namespace, compiled: Compiled) -> Health:
    from rac.targets.coverage import Health

    snapshot = _Snapshot()
    bus, close = _bus(ros_version(args))
    try:
        bus.on_rows(DIAGNOSIS, snapshot.on_diagnosis, 10, latched=True)
        bus.on_rows(OBSERVATIONS, snapshot.on_observations, 50, latched=True)
        deadline = time.monotonic() + args.timeout
        while snapshot.diagnosis is None and time.monotonic() < deadline and bus.ok:
            time.sleep(0.05)
        time.sleep(SETTLE_S)
    finally:
        close()
    with snapshot.lock:
        rows, held = snapshot.diagnosis, dict(snapshot.observations)
    if rows is None:
        raise RacError(
            [
                Diagnostic(
                    "RAC069",
                    f"nothing arrived on {DIAGNOSIS} within {args.timeout:g} s",
                    hint="start racc's runtime (roslaunch DIR/observers.launch) or give a "
                    "longer --timeout",
                )
            ]
        )
    diagnoses = tuple(d for d in (row_diagnosis(r) for r in rows) if d is not None)
    bad = sum(1 for v in held.values() if not v)
    stamp = time.strftime("%H:%M:%S", time.localtime())
    what = f"live at {stamp}, {len(held)} observations, {bad} bad"
    return Health(diagnosis_title(diagnoses, not rows, what), diagnoses, tuple(held.items()))
