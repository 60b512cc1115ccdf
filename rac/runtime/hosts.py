"""The observer hosts the engine hears from (issue 28): one per machine of the robot.

Every row a host publishes on ``/observations`` names it (value ``host``).  The engine
merges the rows of all hosts into one Θ; a host not heard for ``lost_after_s`` (it
republishes its whole set every second) is lost: its atoms become unknown (out of Θ, never
counted as faults), and its loss is a status of its own on ``/diagnostics`` (ERROR) and a
line in the engine's log, until it is heard again.
"""

from __future__ import annotations

from collections.abc import Iterable

from rac.logic import Atom
from rac.runtime.status import ERROR, OK, Row

HOST_LOST_S = 5.0


class HostWatch:
    def __init__(self, lost_after_s: float = HOST_LOST_S) -> None:
        self.lost_after_s = lost_after_s
        self.atoms: dict[str, set[Atom]] = {}
        self.heard: dict[str, float] = {}
        self.lost: dict[str, float] = {}  # lost hosts, since when

    def heard_from(self, host: str, atoms: Iterable[Atom], t: float) -> bool:
        """Rows of ``host`` at ``t``; True when the host was lost and is back."""
        self.atoms.setdefault(host, set()).update(atoms)
        self.heard[host] = t
        return self.lost.pop(host, None) is not None

    def newly_lost(self, now: float) -> list[tuple[str, frozenset[Atom]]]:
        """Hosts silent for ``lost_after_s`` since the last call, with the atoms they had
        reported."""
        out = []
        for host, t in sorted(self.heard.items()):
            if host not in self.lost and now - t >= self.lost_after_s:
                self.lost[host] = now
                out.append((host, frozenset(self.atoms.get(host, ()))))
        return out

    def rows(self, engine: str, now: float) -> tuple[Row, ...]:
        """One ``/diagnostics`` status per host: OK while heard, ERROR once lost."""
        out = []
        for host, t in sorted(self.heard.items()):
            count = len(self.atoms.get(host, ()))
            values = (("last_heard_s", f"{now - t:.1f}"), ("atoms", str(count)))
            if host in self.lost:
                message = (
                    f"lost: no /observations for {now - t:.1f} s; its {count} atoms are unknown"
                )
                out.append(Row(f"{engine}: observer host {host}", ERROR, message, host, values))
            else:
                out.append(Row(f"{engine}: observer host {host}", OK, "heard", host, values))
        return tuple(out)


def lost_line(t: float, host: str, atoms: frozenset[Atom], silent_s: float) -> str:
    """A greppable log line: ``t=… observer host racc_observer_laptop lost …``."""
    return (
        f"t={t:.3f} observer host {host} lost: no /observations for {silent_s:.1f} s; "
        f"{len(atoms)} atoms unknown: {', '.join(sorted(map(str, atoms)))}"
    )
