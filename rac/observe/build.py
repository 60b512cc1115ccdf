"""Observers from their specs (the parameters ``observers.yaml`` holds)."""

from __future__ import annotations

from collections.abc import Callable, Iterable

from rac.errors import Diagnostic, RacError
from rac.observe.base import Observer
from rac.observe.biqobs import BiQObs
from rac.observe.dobs import DObs
from rac.observe.gobs import GObs
from rac.observe.hobs import HObs
from rac.observe.iobs import IObs
from rac.observe.nobs import NObs
from rac.observe.params import spec_error
from rac.observe.pobs import PObs
from rac.observe.qobs import QObs
from rac.passes.observers import ObserverSpec

KINDS: dict[str, Callable[[ObserverSpec], Observer]] = {
    "NObs": NObs,
    "GObs": GObs,
    "PObs": PObs,
    "DObs": DObs,
    "HObs": HObs,
    "BiQObs": BiQObs,
    "IObs": IObs,
}


def build(spec: ObserverSpec) -> Observer:
    """The observer ``spec`` describes; RacError RAC050/RAC051 when it cannot be built."""
    make = KINDS.get(spec.kind)
    if make is None:
        error = spec_error(spec, f"unknown observer kind {spec.kind!r}")
        known = ", ".join(sorted(KINDS))
        raise RacError([Diagnostic("RAC050", error.diagnostics[0].message, hint=f"known: {known}")])
    return make(spec)


def build_all(specs: Iterable[ObserverSpec]) -> tuple[Observer, ...]:
    """Every observer; all the specs' errors at once."""
    built: list[Observer] = []
    problems: list[Diagnostic] = []
    for spec in specs:
        try:
            built.append(build(spec))
        except RacError as error:
            problems.extend(error.diagnostics)
    if problems:
        raise RacError(problems)
    _share_trends(built)
    return tuple(built)


def _share_trends(observers: list[Observer]) -> None:
    """One trend per signal: relations that share a side (a 100 Hz IMU heading in two
    relations) share its QObs, which skips a message it has already taken."""
    pool: dict[tuple[str, str, bool, float, float | None], QObs] = {}
    for obs in observers:
        if not isinstance(obs, BiQObs):
            continue
        for attr, topic, field in (
            ("side1", obs.topic1, obs.field1),
            ("side2", obs.topic2, obs.field2),
        ):
            side: QObs = getattr(obs, attr)
            key = (topic, field, side.integral, side.ws, side.slope)
            setattr(obs, attr, pool.setdefault(key, side))
