"""stackik: inverse kinematics and sensitivity minimisation of stacked Stewart platforms."""

__version__ = "0.1.0"

__all__ = ["__version__"]
