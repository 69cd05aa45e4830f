"""The integration methods of the engine, named in one place.

Every integration method gearsym offers is one frozen :class:`IntegrationMethod` entry of
:data:`INTEGRATION_METHODS`: which SUNDIALS integrator runs it (CVODE or IDA), its linear
multistep family, the model forms it is offered for, the nonlinear iterations and linear
solvers that apply, what it supports (variational equations, parameter sensitivities) and the
``GS_METHOD_*`` code of
``gs_driver.h`` that selects the integrator in C.  Everything that names, checks or lists
methods reads this registry:

* the engine's C call (:meth:`gearsym.engine.driver.Engine.run`, the evaluators of THE Newton
  iteration in :mod:`gearsym.engine.shoot`): the C codes of a method and of its settings (the
  iteration runs in C with every method: its evaluations are the driver's runs);
* :meth:`gearsym.System.simulate` / :meth:`~gearsym.System.flow`: the default method of a
  model form and the checks of a requested one;
* a scene's ``[simulate] method`` (:mod:`gearsym.spec.settings`) and ``gearsym simulate
  --method``: the names;
* the exported C program and FMU (:mod:`gearsym.export.model_info`): a table of the names,
  codes and iterations, compiled into ``gs_export_data.h``;
* the analysis: the predicates :func:`supports_monodromy`, :func:`supports_sensitivities`,
  :func:`default_method`, so that no analysis module names a method.

The module is data and checks only (it imports nothing of gearsym but :mod:`gearsym.errors` and
:mod:`gearsym.options`), so the lowest layer that reads a method name, the scene's settings, may
use it too.
Adding a method is one entry here plus the C it needs (``docs/contributing.md``, "Adding a
solver method").
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

from .errors import ParameterError
from .options import did_you_mean

__all__ = ["DEFAULT_METHOD", "EXPLICIT", "IMPLICIT", "INTEGRATION_METHODS", "LINEAR_SOLVERS", "NONLINEAR",
           "IntegrationMethod", "by_code", "check_method", "default_method", "get_method", "method_names",
           "supports_monodromy", "supports_sensitivities"]

#: The model forms: ``x' = f(t, x, p)`` and the residual (mass-matrix, DAE) form.
EXPLICIT, IMPLICIT = "explicit", "implicit"

#: CVODE's nonlinear iterations: name -> ``GS_NONLIN_*`` code of gs_driver.h (``"auto"``: the
#: method's own, the first of :attr:`IntegrationMethod.nonlinear`).
NONLINEAR: Mapping[str, int] = MappingProxyType({"auto": 0, "newton": 1, "fixedpoint": 2})
#: Newton's linear solvers: name -> ``GS_LINSOL_*`` code (``"auto"``: block-diagonal with
#: variational equations, dense without).
LINEAR_SOLVERS: Mapping[str, int] = MappingProxyType({"auto": 0, "dense": 1, "blockdiag": 2})


@dataclass(frozen=True)
class IntegrationMethod:
    """One integration method of the engine.

    Attributes
    ----------
    name : str
        What users write (``method = "bdf"``, ``--method bdf``, ``simulate(method="bdf")``).
    integrator : str
        The SUNDIALS integrator: ``"CVODE"`` (``x' = f``) or ``"IDA"`` (``F(t, x, x') = 0``).
    family : str
        Its linear multistep family: ``"BDF"`` or ``"Adams-Moulton"``.
    code : int
        The ``GS_METHOD_*`` code of ``gs_driver.h`` (``gs_sim_args.method``): which integrator
        and family the driver creates.  Methods that differ only in their settings share it.
    forms : tuple of str
        The model forms the method is offered for (:data:`EXPLICIT`, :data:`IMPLICIT`).
    nonlinear : tuple of str
        The nonlinear iterations that apply (names of :data:`NONLINEAR`); the first is the one
        ``"auto"`` selects.
    linear_solvers : tuple of str
        Newton's linear solvers that apply (names of :data:`LINEAR_SOLVERS`; empty: no Newton).
    monodromy : bool
        The variational equations (the monodromy with saltation matrices) are integrated:
        shooting (its Newton matrix) and the Floquet multipliers need them.
    sensitivities : bool
        Forward parameter sensitivities with event-time terms are integrated: the
        continuation's exact ``F_lambda`` (its residuals evaluated in C) needs them.
    summary : str
        One line for help texts and the documentation.
    """

    name: str
    integrator: str
    family: str
    code: int
    forms: tuple[str, ...]
    nonlinear: tuple[str, ...]
    linear_solvers: tuple[str, ...]
    monodromy: bool
    sensitivities: bool
    summary: str

    def nonlinear_code(self, requested: str = "auto") -> int:
        """The ``GS_NONLIN_*`` code of the nonlinear iteration ``requested`` with this method.

        Raises
        ------
        ParameterError
            An unknown iteration, or one this method does not use.
        """
        if requested not in NONLINEAR:
            raise ParameterError(f"unknown nonlinear solver {requested!r}{did_you_mean(requested, NONLINEAR)}; "
                                 f"use one of {sorted(NONLINEAR)}")
        if requested == "auto":
            return NONLINEAR[self.nonlinear[0]]
        if requested not in self.nonlinear:
            raise ParameterError(f"method '{self.name}' has no {requested!r} nonlinear iteration (it uses "
                                 f"{', '.join(self.nonlinear)})")
        return NONLINEAR[requested]

    def linear_solver_code(self, requested: str = "auto") -> int:
        """The ``GS_LINSOL_*`` code of Newton's linear solver ``requested`` with this method.

        Raises
        ------
        ParameterError
            An unknown linear solver, or one this method does not use.
        """
        if requested not in LINEAR_SOLVERS:
            raise ParameterError(f"unknown linear solver {requested!r}{did_you_mean(requested, LINEAR_SOLVERS)}; "
                                 f"use one of {sorted(LINEAR_SOLVERS)}")
        if requested != "auto" and requested not in self.linear_solvers:
            uses = ", ".join(self.linear_solvers) or "no linear solver (no Newton iteration)"
            raise ParameterError(f"method '{self.name}' has no {requested!r} linear solver (it uses {uses})")
        return LINEAR_SOLVERS[requested]


_CVODE_LINEAR = ("dense", "blockdiag")

#: Every integration method, in the order the documentation and the messages list them.
INTEGRATION_METHODS: Mapping[str, IntegrationMethod] = MappingProxyType({m.name: m for m in (
    IntegrationMethod("adams", "CVODE", "Adams-Moulton", 1, (EXPLICIT,), ("newton", "fixedpoint"), _CVODE_LINEAR,
                      monodromy=True, sensitivities=True,
                      summary="CVODE, Adams-Moulton orders 1-12, modified Newton with the analytic Jacobian "
                              "(non-stiff models: fewer, more accurate steps)"),
    IntegrationMethod("bdf", "CVODE", "BDF", 0, (EXPLICIT,), ("newton", "fixedpoint"), _CVODE_LINEAR,
                      monodromy=True, sensitivities=True,
                      summary="CVODE, BDF orders 1-5, modified Newton with the analytic Jacobian (stiff models)"),
    IntegrationMethod("ida", "IDA", "BDF", 2, (IMPLICIT,), ("newton",), _CVODE_LINEAR,
                      monodromy=True, sensitivities=True,
                      summary="IDA, BDF orders 1-5 on the residual F(t, x, x') = 0 (implicit and DAE models)"),
    IntegrationMethod("adams_fixedpoint", "CVODE", "Adams-Moulton", 1, (EXPLICIT,), ("fixedpoint",), (),
                      monodromy=True, sensitivities=True,
                      summary="CVODE, Adams-Moulton with the fixed-point (functional) iteration: no Jacobian and "
                              "no linear algebra (large non-stiff models)"),
)})

#: The method of each model form when neither the caller nor the scene names one.
DEFAULT_METHOD: Mapping[str, str] = MappingProxyType({EXPLICIT: "adams", IMPLICIT: "ida"})


def method_names(form: str | None = None) -> tuple[str, ...]:
    """The names of the methods (of those offered for ``form``, :data:`EXPLICIT` or
    :data:`IMPLICIT`, when given), in registry order."""
    return tuple(n for n, m in INTEGRATION_METHODS.items() if form is None or form in m.forms)


def get_method(name: str) -> IntegrationMethod:
    """The registry entry of ``name``.

    Raises
    ------
    ParameterError
        An unknown name (with the closest known one and the list).
    """
    try:
        return INTEGRATION_METHODS[name]
    except (KeyError, TypeError):
        raise ParameterError(f"unknown method {name!r}{did_you_mean(name, INTEGRATION_METHODS)}; use one of "
                             f"{', '.join(INTEGRATION_METHODS)}") from None


def by_code(code: int) -> IntegrationMethod:
    """The first method with the C code ``code`` (its plain settings: ``"adams"`` for 1).

    Raises
    ------
    ParameterError
        No method has that code.
    """
    for m in INTEGRATION_METHODS.values():
        if m.code == code:
            return m
    raise ParameterError(f"unknown method code {code!r}; use one of "
                         f"{sorted({m.code for m in INTEGRATION_METHODS.values()})}")


def default_method(implicit: bool, preferred: str | None = None) -> str:
    """The method of a run: ``preferred`` (the caller's or the scene's), else the default of
    the model's form; an implicit model always runs on its form's method."""
    if implicit:
        return DEFAULT_METHOD[IMPLICIT]
    return str(preferred or DEFAULT_METHOD[EXPLICIT])


def check_method(name: str, implicit: bool) -> IntegrationMethod:
    """The entry of ``name`` if it is offered for a model of this form.

    Raises
    ------
    ParameterError
        An unknown method, or one not offered for the model's form (naming the ones that are).
    """
    if name not in INTEGRATION_METHODS:
        raise ParameterError(f"method must be one of {', '.join(method_names())}, got '{name}'"
                             f"{did_you_mean(name, INTEGRATION_METHODS)}")
    m = INTEGRATION_METHODS[name]
    form = IMPLICIT if implicit else EXPLICIT
    if form in m.forms:
        return m
    if implicit:
        use = " or ".join(f"method='{n}'" for n in method_names(IMPLICIT))
        raise ParameterError(f"this model is in implicit (mass-matrix) form: use {use}")
    raise ParameterError(f"method='{name}' needs a model in implicit form (model.form = 'implicit')")


def _supports(name: str | None, flag: str) -> bool:
    m = INTEGRATION_METHODS.get(name) if isinstance(name, str) else None
    return bool(m is not None and getattr(m, flag))


def supports_sensitivities(name: str | None) -> bool:
    """Whether method ``name`` integrates forward parameter sensitivities (False for unknown names)."""
    return _supports(name, "sensitivities")


def supports_monodromy(name: str | None) -> bool:
    """Whether method ``name`` integrates the variational equations (False for unknown names)."""
    return _supports(name, "monodromy")
