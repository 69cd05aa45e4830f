"""Symbolic layer: equations of motion, modes, Jacobians and dimensionless forms (sympy)."""

from .model import Mode, ScheduleInfo, SwitchingFunction, SymbolicModel

__all__ = ["Mode", "ScheduleInfo", "SwitchingFunction", "SymbolicModel"]
