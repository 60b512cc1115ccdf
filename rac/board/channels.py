"""Which device sits on which board channel, taken from the model (§4.2.1, chapter 8).

The original client hard-coded this map; here it is the model's switchable hardware at
their ``channel`` numbers, every other channel spare.  Also the hardware observer's
literals (HObs, §5.2.6) read off one MSR.
"""

from __future__ import annotations

from dataclasses import dataclass

from rac.board.protocol import ChannelSpec, Measurements
from rac.errors import Diagnostic, RacError, did_you_mean
from rac.ir import Model
from rac.logic import NEG_PREFIX, mangle

DEFAULT_CHANNELS = 10  # §8.2.1: ten channels
HIGH_POWER_CHANNELS = 3  # §8.2.1: three of 15 A / 60 V, the rest 5 A / 20 V
HIGH_POWER = ChannelSpec(max_current=15.0, max_voltage=60.0)
LOW_POWER = ChannelSpec(max_current=5.0, max_voltage=20.0)


@dataclass(frozen=True, slots=True)
class ChannelMap:
    """Device name per 1-based channel number, sorted by channel."""

    devices: tuple[tuple[int, str], ...] = ()

    def device(self, channel: int) -> str | None:
        return dict(self.devices).get(channel)

    def channel(self, device: str) -> int | None:
        return {d: c for c, d in self.devices}.get(device)

    @property
    def highest(self) -> int:
        return max((c for c, _ in self.devices), default=0)


def channel_map(model: Model) -> ChannelMap:
    pairs = (
        (h.channel, h.name.value) for h in model.hardware if h.switchable and h.channel is not None
    )
    return ChannelMap(tuple(sorted(pairs)))


def default_specs(count: int) -> tuple[ChannelSpec, ...]:
    return tuple(HIGH_POWER if i < HIGH_POWER_CHANNELS else LOW_POWER for i in range(count))


def resolve_target(target: str, channels: ChannelMap, count: int | None = None) -> int:
    """A channel number from a device name of the model or a channel number.

    ``count``, when known (from the board's INT), bounds the channel number.
    """
    if target.isdigit():
        number = int(target)
        if number < 1 or (count is not None and number > count):
            bound = f"1..{count}" if count is not None else "1 or more"
            raise RacError(
                [Diagnostic("RAC092", f"channel {number} is not on the board ({bound})")]
            )
        return number
    number_of_device = channels.channel(target)
    if number_of_device is None:
        names = [d for _, d in channels.devices]
        known = ", ".join(names) if names else "none (give --model, or a channel number)"
        raise RacError(
            [
                Diagnostic(
                    "RAC092",
                    f"unknown device '{target}'; switchable devices: {known}",
                    hint=did_you_mean(target, names),
                )
            ]
        )
    return number_of_device


def check_fits(channels: ChannelMap, count: int) -> None:
    """The board must have every channel the model names."""
    beyond = [(c, d) for c, d in channels.devices if c > count]
    if beyond:
        names = ", ".join(f"{d} (channel {c})" for c, d in beyond)
        raise RacError(
            [Diagnostic("RAC094", f"the board has {count} channels; the model puts {names} beyond")]
        )


def hobs_literals(channels: ChannelMap, msr: Measurements) -> tuple[str, ...]:
    """``on(h)`` or ``not_on(h)`` per model device the MSR covers, by channel (Algorithm 6)."""
    out = []
    for number, device in channels.devices:
        if number <= len(msr.channels):
            atom = f"on({mangle(device)})"
            out.append(atom if msr.channels[number - 1].on else NEG_PREFIX + atom)
    return tuple(out)
