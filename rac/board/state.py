"""The simulated board's channels: what it measures, how it switches, which faults it has.

Kept apart from the network code so the control interface and tests can drive it directly.
The measurements are plausible, not physical: a device draws a nominal current fixed by
its name (so runs repeat), with a little seeded jitter.
"""

from __future__ import annotations

import random
import zlib
from dataclasses import dataclass

from rac.board.channels import ChannelMap, default_specs
from rac.board.protocol import ChannelSpec, Init, Measurements, Reading
from rac.compat import StrEnum

JITTER = 0.02  # ± fraction of the nominal value
OVERCURRENT_FACTOR = 1.25  # an over-current fault draws this much of the channel's maximum


class Fault(StrEnum):
    OVERCURRENT = "overcurrent"  # draws more than the channel's maximum
    DISCONNECTED = "disconnected"  # powered, but nothing draws current
    JAMMED = "jammed"  # the relay no longer switches: SWT is ACKed and ignored


@dataclass(slots=True)
class SimChannel:
    number: int
    device: str | None
    spec: ChannelSpec
    on: bool
    fault: Fault | None = None

    @property
    def nominal_voltage(self) -> float:
        return 24.0 if self.spec.max_voltage > 30.0 else 12.0

    @property
    def nominal_current(self) -> float:
        if self.device is None:
            return 0.0
        # A stable per-device draw between 10 % and 40 % of the channel's maximum.
        share = 0.1 + 0.3 * (zlib.crc32(self.device.encode()) % 1000) / 1000
        return round(self.spec.max_current * share, 2)

    @property
    def label(self) -> str:
        return self.device or "spare"


class BoardState:
    """Every channel of one board, shared by all its clients."""

    def __init__(self, channels: ChannelMap, count: int, seed: int = 0) -> None:
        specs = default_specs(count)
        self.channels = [
            SimChannel(i + 1, channels.device(i + 1), spec, on=channels.device(i + 1) is not None)
            for i, spec in enumerate(specs)
        ]
        self._rng = random.Random(seed)

    def init(self) -> Init:
        return Init(tuple(c.spec for c in self.channels))

    def channel(self, number: int) -> SimChannel | None:
        if 1 <= number <= len(self.channels):
            return self.channels[number - 1]
        return None

    def switch(self, number: int, on: bool) -> bool:
        """Set a channel; False when there is no such channel."""
        channel = self.channel(number)
        if channel is None:
            return False
        if channel.fault is not Fault.JAMMED:
            channel.on = on
        return True

    def trip(self, number: int) -> None:
        """The device's supply trips off; it stays off until switched on again."""
        channel = self._get(number)
        channel.on = False

    def inject(self, number: int, fault: Fault) -> None:
        self._get(number).fault = fault

    def clear(self, number: int) -> None:
        self._get(number).fault = None

    def measurements(self) -> Measurements:
        return Measurements(tuple(self._reading(c) for c in self.channels))

    def _reading(self, channel: SimChannel) -> Reading:
        if not channel.on:
            return Reading(False, 0.0, 0.0)
        voltage = self._jitter(channel.nominal_voltage)
        if channel.fault is Fault.OVERCURRENT:
            current = self._jitter(channel.spec.max_current * OVERCURRENT_FACTOR)
        elif channel.fault is Fault.DISCONNECTED:
            current = 0.0
        else:
            current = self._jitter(channel.nominal_current)
        return Reading(True, current, voltage)

    def _jitter(self, value: float) -> float:
        return value * (1.0 + self._rng.uniform(-JITTER, JITTER))

    def _get(self, number: int) -> SimChannel:
        channel = self.channel(number)
        if channel is None:
            raise KeyError(number)
        return channel
