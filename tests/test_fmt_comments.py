"""racc fmt keeps a node body's comments above the statements they describe."""

from __future__ import annotations

from rac.fmt import format_model
from rac.parse import parse_ram

SOURCE = """\
robot x
topic /a : std_msgs/Empty
topic /b : std_msgs/Empty
topic /c : std_msgs/Empty
node n {
  # about the limits
  limits cpu 5 %
  subscribes /a  # the input
  publishes /c
  # why /b depends on /a
  publishes /b from /a
  reports dev
  # closing remark
}
"""

EXPECTED_BODY = """\
node n {
  # the input
  subscribes /a
  publishes /c
  # why /b depends on /a
  publishes /b from /a
  # about the limits
  limits cpu 5 %
  reports dev
  # closing remark
}
"""


def test_body_comments_travel_with_their_statements() -> None:
    formatted = format_model(parse_ram(SOURCE, "x.ram"))
    assert formatted.endswith(EXPECTED_BODY)


def test_formatting_body_comments_is_idempotent() -> None:
    once = format_model(parse_ram(SOURCE, "x.ram"))
    assert format_model(parse_ram(once, "x.ram")) == once
