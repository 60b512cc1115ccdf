"""racc, the robot architecture compiler: declarative models for diagnosis and repair."""

__version__ = "0.1.0"
