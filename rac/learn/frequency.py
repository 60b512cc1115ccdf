"""Frequency observers (Algorithm 15, lines 5-10): which topics are regular, and how regular."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rac.learn.recording import TopicData


@dataclass(frozen=True, slots=True)
class RateStats:
    """Inter-arrival statistics of one topic."""

    topic: str
    samples: int  # intervals measured
    mean: float  # Δ̄, seconds
    stddev: float  # σ, seconds
    regular: bool  # Δ̄/σ > α

    @property
    def ratio(self) -> float:
        return self.mean / self.stddev if self.stddev > 0 else float("inf")

    @property
    def rate_hz(self) -> float:
        return 1.0 / self.mean

    @property
    def tolerance_hz(self) -> float:
        """The rate band whose slower edge is one σ longer than Δ̄.

        The frequency observer accepts a window mean interval within δ ± σ (Algorithm 1);
        the compiler turns a tolerance T back into that σ as 1/(rate - T) - 1/rate.
        """
        return self.rate_hz - 1.0 / (self.mean + self.stddev)


def rate_stats(topic: TopicData, alpha: float) -> RateStats | None:
    """None when the topic has fewer than three intervals (nothing to judge)."""
    deltas = topic.intervals()
    if deltas.size < 3:
        return None
    mean = float(np.mean(deltas))
    stddev = float(np.std(deltas))
    if mean <= 0:
        return RateStats(topic.name, int(deltas.size), mean, stddev, False)
    regular = stddev == 0 or mean / stddev > alpha
    return RateStats(topic.name, int(deltas.size), mean, stddev, regular)


# Message types published when someone or something asks, not at a steady rate (docs/
# language.md, "topic": a joystick, velocity commands, a map updated when the robot moves,
# goals and plans), and the last segments of topic names that say the same.
ON_DEMAND_TYPES = {
    "sensor_msgs/Joy": "a joystick",
    "geometry_msgs/Twist": "velocity commands",
    "geometry_msgs/TwistStamped": "velocity commands",
    "nav_msgs/OccupancyGrid": "a map, updated when the robot moves",
    "nav_msgs/Path": "a plan, made when a goal is given",
    "geometry_msgs/PoseStamped": "a pose, such as a goal",
    "geometry_msgs/PoseWithCovarianceStamped": "a pose, such as an initial pose",
    "move_base_msgs/MoveBaseActionGoal": "goals",
    "actionlib_msgs/GoalID": "goal cancellations",
    "std_msgs/Empty": "events without data",
}
ON_DEMAND_NAMES = {
    "cmd_vel": "velocity commands",
    "joy": "a joystick",
    "goal": "goals",
    "initialpose": "an initial pose",
    "map": "a map, updated when the robot moves",
    "plan": "a plan, made when a goal is given",
    "cancel": "goal cancellations",
}


def on_demand(name: str, msg_type: str | None) -> str | None:
    """Why a topic looks published on demand (by its type or its name), or None.

    A rate learned from such a topic holds while its publisher is asked to publish (the
    demo robot publishes every topic without a rate at 2 Hz; move_base publishes velocity
    commands while it drives): its frequency observer would report a fault whenever it
    is not."""
    last = name.rstrip("/").rsplit("/", 1)[-1]
    if msg_type in ON_DEMAND_TYPES:
        return f"{msg_type}: {ON_DEMAND_TYPES[msg_type]}"
    if last in ON_DEMAND_NAMES:
        return f"named {last}: {ON_DEMAND_NAMES[last]}"
    return None
