"""Physical units: parsing unit strings and checking dimensions.

A unit is a scale to SI and a vector of exponents of the base dimensions
(mass, length, time).  Angles (``rad``) are dimensionless, as in SI.  Unit strings
are products/quotients of known units with integer or rational powers, e.g.
``"kg*m^2"``, ``"N/m"``, ``"N*s/m"``, ``"rad/s"``, ``"1"``.
"""

from __future__ import annotations

import ast
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction

_BASE = ("kg", "m", "s")


@dataclass(frozen=True)
class Unit:
    """A physical unit: ``scale`` times the SI unit with dimension exponents ``dims``."""

    scale: float
    dims: tuple[Fraction, Fraction, Fraction]

    def __mul__(self, other: Unit) -> Unit:
        return Unit(self.scale * other.scale, tuple(a + b for a, b in zip(self.dims, other.dims)))

    def __truediv__(self, other: Unit) -> Unit:
        return Unit(self.scale / other.scale, tuple(a - b for a, b in zip(self.dims, other.dims)))

    def __pow__(self, k: Fraction | int | float) -> Unit:
        k = Fraction(k).limit_denominator(1000)
        return Unit(self.scale ** float(k), tuple(a * k for a in self.dims))

    @property
    def dimensionless(self) -> bool:
        """True if all dimension exponents are zero."""
        return all(d == 0 for d in self.dims)

    def same_dimension(self, other: Unit) -> bool:
        """True if ``self`` and ``other`` measure the same physical quantity."""
        return self.dims == other.dims

    def si_string(self) -> str:
        """The dimension written in SI base units, e.g. ``kg*m^2*s^-2``."""
        parts = []
        for name, d in zip(_BASE, self.dims):
            if d == 0:
                continue
            parts.append(name if d == 1 else f"{name}^{d}")
        return "*".join(parts) if parts else "1"


ONE = Unit(1.0, (Fraction(0), Fraction(0), Fraction(0)))


def _u(scale: float, kg: int = 0, m: int = 0, s: int = 0) -> Unit:
    return Unit(scale, (Fraction(kg), Fraction(m), Fraction(s)))


#: Known unit names.  Deliberately small and explicit; extend as models need.
KNOWN_UNITS: dict[str, Unit] = {
    "1": ONE,
    "rad": ONE,
    "deg": _u(math.pi / 180),
    "rev": _u(2 * math.pi),
    "kg": _u(1.0, kg=1),
    "g": _u(1e-3, kg=1),
    "t": _u(1e3, kg=1),
    "m": _u(1.0, m=1),
    "cm": _u(1e-2, m=1),
    "mm": _u(1e-3, m=1),
    "um": _u(1e-6, m=1),
    "nm": _u(1e-9, m=1),
    "s": _u(1.0, s=1),
    "ms": _u(1e-3, s=1),
    "us": _u(1e-6, s=1),
    "min": _u(60.0, s=1),
    "Hz": _u(1.0, s=-1),
    "rpm": _u(2 * math.pi / 60.0, s=-1),
    "N": _u(1.0, kg=1, m=1, s=-2),
    "kN": _u(1e3, kg=1, m=1, s=-2),
    "J": _u(1.0, kg=1, m=2, s=-2),
    "W": _u(1.0, kg=1, m=2, s=-3),
    "Pa": _u(1.0, kg=1, m=-1, s=-2),
    "MPa": _u(1e6, kg=1, m=-1, s=-2),
    "GPa": _u(1e9, kg=1, m=-1, s=-2),
}


#: Longest unit string.
MAX_UNIT_LENGTH = 200


class UnitSyntaxError(ValueError):
    """A unit string could not be parsed (message says why)."""


def parse_unit(text: str | int | float) -> Unit:
    """Parse a unit string such as ``"N*m"`` or ``"kg*m^2"``.

    Parameters
    ----------
    text
        The unit. ``"1"``, ``""`` and the number ``1`` mean dimensionless.

    Returns
    -------
    Unit

    Raises
    ------
    UnitSyntaxError
        If the string is not a product of known units with numeric powers.
    """
    if isinstance(text, (int, float)) and text == 1:
        return ONE
    if not isinstance(text, str):
        raise UnitSyntaxError(f"a unit must be a string, got {type(text).__name__}")
    src = text.strip().replace("^", "**")
    if src in ("", "1", "-"):
        return ONE
    if len(src) > MAX_UNIT_LENGTH or not src.isascii():
        raise UnitSyntaxError(f"cannot parse unit '{text[:40]}': a unit is a short ASCII product of "
                              f"known units with numeric powers")
    try:
        tree = ast.parse(src, mode="eval")
        return _eval_unit(tree.body, text)
    except (SyntaxError, ValueError, RecursionError, MemoryError, OverflowError) as exc:
        if isinstance(exc, UnitSyntaxError):
            raise
        raise UnitSyntaxError(f"cannot parse unit '{text}'") from None


def _eval_unit(node: ast.AST, text: str) -> Unit:
    if isinstance(node, ast.Name):
        if node.id not in KNOWN_UNITS:
            known = ", ".join(sorted(KNOWN_UNITS))
            raise UnitSyntaxError(f"unknown unit '{node.id}' in '{text}' (known: {known})")
        return KNOWN_UNITS[node.id]
    if isinstance(node, ast.Constant) and node.value == 1:
        return ONE
    if isinstance(node, ast.BinOp):
        if isinstance(node.op, ast.Mult):
            return _eval_unit(node.left, text) * _eval_unit(node.right, text)
        if isinstance(node.op, ast.Div):
            return _eval_unit(node.left, text) / _eval_unit(node.right, text)
        if isinstance(node.op, ast.Pow):
            exp = _number(node.right)
            if exp is None:
                raise UnitSyntaxError(f"unit exponent must be a number in '{text}'")
            if abs(exp) > 12:
                raise UnitSyntaxError(f"unit exponent {float(exp):g} is too large in '{text}'")
            return _eval_unit(node.left, text) ** exp
    raise UnitSyntaxError(f"cannot parse unit '{text}'")


def _number(node: ast.AST) -> Fraction | None:
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
        return Fraction(node.value).limit_denominator(1000)
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        v = _number(node.operand)
        return None if v is None else -v
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div):
        a, b = _number(node.left), _number(node.right)
        if a is not None and b is not None and b != 0:
            return a / b
    return None


# ------------------------------------------------- the one unit conversion of the public API
class ParameterUnits:
    """The declared unit of every model parameter, and the one conversion to and from SI.

    Every parameter value that crosses gearsym's public API is in the unit the model
    declares for it (``b_m = { value = 50.0, unit = "um" }`` -> ``b_m=50`` means 50 um):
    :func:`gearsym.load_scene` overrides, ``params=`` of every
    :class:`~gearsym.system.System` method, ``System.params``, the ``params`` of
    trajectories and orbits, continuation ranges and branch values, map grids, and the
    command line.  Inside (generated C, the engine, the parameter vectors of
    :meth:`~gearsym.system.System.param_vector`) everything is SI; the conversion happens
    here, once, where a value enters or leaves.

    Parameters
    ----------
    units
        Parameter name -> declared unit text.
    scales
        Parameter name -> SI value of one declared unit (``1e-6`` for ``um``).  A name
        without an entry (a bound parameter, a model without declared units) is SI.
    """

    __slots__ = ("scales", "units")

    def __init__(self, units: Mapping[str, str] | None = None, scales: Mapping[str, float] | None = None):
        self.units: dict[str, str] = dict(units or {})
        self.scales: dict[str, float] = {k: float(v) for k, v in (scales or {}).items()}

    @classmethod
    def of_model(cls, model) -> ParameterUnits:
        """The declared units of a :class:`~gearsym.spec.model.ModelSpec`'s parameters."""
        return cls({n: p.unit for n, p in model.parameters.items()},
                   {n: p.si_scale for n, p in model.parameters.items()})

    def __getstate__(self) -> tuple[dict[str, str], dict[str, float]]:
        return self.units, self.scales

    def __setstate__(self, state: tuple[dict[str, str], dict[str, float]]) -> None:
        self.units, self.scales = state

    def __repr__(self) -> str:
        scaled = {n: self.units[n] for n, s in self.scales.items() if s != 1.0}
        return f"ParameterUnits({len(self.units)} parameters, not SI: {scaled})"

    def scale(self, name: str) -> float:
        """SI value of one declared unit of ``name`` (1 for SI and unknown names)."""
        return self.scales.get(name, 1.0)

    def unit(self, name: str) -> str:
        """The declared unit of ``name`` (``""`` if none is declared)."""
        return self.units.get(name, "")

    def declared_value(self, name: str, value: object) -> float:
        """A parameter value given by a user, in the declared unit of ``name``.

        A number (or a string that is one) is already in the declared unit.  A string
        that is a number followed by a unit this module knows (``"50um"``, ``"2e13 N/m"``,
        ``"3000 rpm"``) is converted to the declared unit, after checking that the two
        units measure the same quantity.

        Parameters
        ----------
        name
            The parameter.
        value
            A number, or a string: a number, optionally followed by a unit.

        Returns
        -------
        float
            The value in the declared unit of ``name`` (not checked for finiteness).

        Raises
        ------
        ValueError
            A string that is not a number (with a known unit), or a unit of another
            dimension; the message says that values are in the declared unit and names it.
        """
        if isinstance(value, bool):
            raise ValueError(f"expected a number, got {value!r} ({self._declared_hint(name)})")
        if isinstance(value, (int, float)) or hasattr(value, "__float__") and not isinstance(value, str):
            return float(value)  # type: ignore[arg-type]
        if not isinstance(value, str):
            raise ValueError(f"expected a number, got {type(value).__name__} ({self._declared_hint(name)})")
        text = value.strip()
        try:
            return float(text)
        except ValueError:
            pass
        m = _QUANTITY.fullmatch(text)
        shown = text if len(text) <= 60 else text[:57] + "..."
        if m is None or not m.group(2):
            raise ValueError(f"'{shown}' is not a number ({self._declared_hint(name)}; a number with a unit "
                             f"such as 50um or '2e13 N/m' is converted to it)")
        unit_text = m.group(2)
        try:
            given = parse_unit(unit_text)
        except UnitSyntaxError as exc:
            raise ValueError(f"'{shown}': {exc} ({self._declared_hint(name)})") from None
        declared_text = self.units.get(name) or "1"
        declared = parse_unit(declared_text)
        if not given.same_dimension(declared):
            raise ValueError(f"'{shown}' is [{given.si_string()}] but '{name}' is declared in "
                             f"{declared_text} [{declared.si_string()}]: give a value in {declared_text} "
                             f"or in a unit of the same dimension")
        if _mentions_hz(unit_text) != _mentions_hz(declared_text):  # 1 Hz = 2*pi rad/s, not 1 rad/s
            raise ValueError(f"'{shown}': Hz (cycles per second) and angular frequencies (rad/s, rpm) are "
                             f"not converted into each other: give the value in {declared_text}")
        # exact decimal arithmetic on the written number and the unit scales: 0.05mm is 50 um, not
        # 50.00000000000001 um
        return float(Fraction(m.group(1)) * Fraction(repr(given.scale)) / Fraction(repr(declared.scale)))

    def _declared_hint(self, name: str) -> str:
        unit = self.units.get(name) or "1"
        if unit in ("", "1"):
            return f"'{name}' is dimensionless: values are plain numbers"
        return f"values are in the declared unit of '{name}', {unit}: {name}=50 means 50 {unit}"

    def to_si(self, values: Mapping[str, float] | None) -> dict[str, float]:
        """Declared values -> SI values (names without a declared unit unchanged; numbers or arrays)."""
        return {k: _scaled(v, self.scales.get(k, 1.0)) for k, v in (values or {}).items()}

    def to_declared(self, values: Mapping[str, float] | None) -> dict[str, float]:
        """SI values -> declared values (the inverse of :meth:`to_si`: ``to_si`` of the result gives
        the SI values back exactly, and a value set as ``50`` um reads back as ``50.0``, not
        ``49.99999999999999``)."""
        return {k: _declared(v, self.scales.get(k, 1.0)) for k, v in (values or {}).items()}


#: a number followed by a unit: ``50um``, ``2e13 N/m``, ``-3.5e-6 m``
_QUANTITY = re.compile(r"([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(\S.*)?")


def _mentions_hz(unit_text: str) -> bool:
    return re.search(r"(?<![A-Za-z])Hz(?![A-Za-z])", unit_text) is not None


def _declared(v, scale: float):
    """The shortest decimal ``d`` with ``d * scale == v`` (else ``v / scale``); arrays divided."""
    if scale == 1.0:
        return _scaled(v, 1.0)
    if hasattr(v, "shape") and getattr(v, "ndim", 0):
        return v / scale
    x = float(v) / scale
    for digits in (15, 16, 17):
        d = float(f"{x:.{digits}g}")
        if d * scale == float(v):
            return d
    return x


def _scaled(v, factor: float):
    """``v * factor``: a float for a number, an array for an array."""
    return v * factor if hasattr(v, "shape") and getattr(v, "ndim", 0) else float(v) * factor
