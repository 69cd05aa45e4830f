"""Numeric functions of parameters that model expressions may call.

Some model quantities are functions of parameters only but have no closed form, e.g.
the mean asperity height of a Weierstrass-Mandelbrot surface (an integral of the
absolute value of an infinite series).  A model expression may call them with
parameter names as arguments (``wm_mean_height(D, G, lam, L_c, l_a)``); the spec layer
checks the call (:data:`gearsym.spec.expressions.BOUND_FUNCTIONS` holds the argument
and result dimensions), the symbolic layer replaces each distinct call by a
parameter-like symbol, and :class:`gearsym.system.System` evaluates it here whenever
the parameters are bound (before each run), so the generated C only sees a number.
No sympy here.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from .errors import ParameterError
from .fractal import wm_mean_height

#: name -> implementation (arguments in SI units, result in SI units)
IMPLEMENTATIONS: dict[str, Callable[..., float]] = {
    "wm_mean_height": wm_mean_height,
}


def evaluate(name: str, args: Sequence[float], arg_names: Sequence[str] | None = None) -> float:
    """Evaluate a bound function.

    Parameters
    ----------
    name
        The function.
    args
        Its arguments (SI values).
    arg_names
        The model's parameters passed as its arguments: an error then names the call as the
        model writes it (``wm_mean_height(D, G, lam, L_c, l_a): ...``).

    Raises
    ------
    ParameterError
        Unknown function, arguments it refuses, or a non-finite result.
    """
    try:
        fn = IMPLEMENTATIONS[name]
    except KeyError:
        raise ParameterError(f"unknown bound function '{name}' (known: {', '.join(IMPLEMENTATIONS)})") \
            from None
    call = f"{name}({', '.join(arg_names)})" if arg_names is not None else name
    try:
        value = float(fn(*[float(a) for a in args]))
    except ParameterError as exc:
        text = str(exc)
        raise ParameterError(f"{call}: {text.removeprefix(name + ': ')}") from None
    if not math.isfinite(value):
        raise ParameterError(f"{call} is not finite (arguments {tuple(args)})")
    return value
