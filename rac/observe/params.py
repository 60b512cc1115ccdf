"""Reading an observer's parameters (those ``observers.yaml`` holds), with RAC050/RAC051.

RAC050: an unknown observer kind, or a parameter missing or of the wrong type.  RAC051: a
parameter of the right type whose value cannot work (a non-positive window, a malformed
channel list).  Both name the observer.
"""

from __future__ import annotations

import math

from rac.errors import Diagnostic, RacError
from rac.logic import Atom
from rac.passes.observers import ObserverSpec, ParamValue


def spec_error(spec: ObserverSpec, message: str, code: str = "RAC050") -> RacError:
    return RacError([Diagnostic(code, f"observer '{spec.name}' ({spec.kind}): {message}")])


class Params:
    """Typed access to one spec's parameters; every error names the observer."""

    def __init__(self, spec: ObserverSpec) -> None:
        self.spec = spec
        self._values: dict[str, ParamValue] = dict(spec.params)

    def _get(self, key: str) -> ParamValue | None:
        return self._values.get(key)

    def _missing(self, key: str) -> RacError:
        return spec_error(self.spec, f"missing parameter '{key}'")

    def _ill_typed(self, key: str, value: object, wanted: str) -> RacError:
        return spec_error(self.spec, f"parameter '{key}' must be {wanted}, not {value!r}")

    def text(self, key: str, default: str | None = None) -> str:
        value = self._get(key)
        if value is None:
            if default is None:
                raise self._missing(key)
            return default
        if not isinstance(value, str) or not value.strip():
            raise self._ill_typed(key, value, "a non-empty string")
        return value.strip()

    def number(self, key: str, default: float | None = None) -> float:
        value = self._get(key)
        if value is None:
            if default is None:
                raise self._missing(key)
            return default
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self._ill_typed(key, value, "a number")
        if not math.isfinite(value):
            raise self._ill_typed(key, value, "a finite number")
        return float(value)

    def optional_number(self, key: str) -> float | None:
        return None if self._get(key) is None else self.number(key)

    def positive(self, key: str, default: float | None = None) -> float:
        value = self.number(key, default)
        if value <= 0:
            raise spec_error(
                self.spec, f"parameter '{key}' must be positive, not {value}", "RAC051"
            )
        return value

    def non_negative(self, key: str, default: float) -> float:
        value = self.number(key, default)
        if value < 0:
            raise spec_error(
                self.spec, f"parameter '{key}' must be zero or more, not {value}", "RAC051"
            )
        return value

    def count(self, key: str, default: int | None = None) -> int:
        value = self._get(key)
        if value is None:
            if default is None:
                raise self._missing(key)
            return default
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise self._ill_typed(key, value, "a non-negative integer")
        return value

    def flag(self, key: str, default: bool = False) -> bool:
        value = self._get(key)
        if value is None:
            return default
        if isinstance(value, bool):
            return value
        if isinstance(value, int) and value in (0, 1):
            return bool(value)
        if isinstance(value, str) and value.strip().lower() in ("true", "false"):
            return value.strip().lower() == "true"
        raise self._ill_typed(key, value, "true or false")

    def atom(self, index: int = 0) -> Atom:
        if len(self.spec.atoms) <= index:
            raise spec_error(self.spec, f"needs at least {index + 1} atom(s) to report")
        return self.spec.atoms[index]
