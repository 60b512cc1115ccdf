"""What racc needs from Python 3.11+ on 3.10 too (ROS 2 Humble runs Python 3.10).

Elsewhere: asyncio's time-outs are caught as ``(TimeoutError, asyncio.TimeoutError)``, since
before 3.11 ``asyncio.TimeoutError`` is not the built-in ``TimeoutError``.
"""

from __future__ import annotations

import enum
import sys

if sys.version_info >= (3, 11):
    from enum import StrEnum
else:

    class StrEnum(str, enum.Enum):
        """3.11's StrEnum: members are strings and print as their value."""

        def __str__(self) -> str:
            return str(self.value)

        def __format__(self, spec: str) -> str:
            return format(str(self.value), spec)


__all__ = ["StrEnum"]
