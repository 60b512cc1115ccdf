"""racc, the robot architecture compiler: declarative models for model-based diagnosis and repair."""

__version__ = "0.1.0"
