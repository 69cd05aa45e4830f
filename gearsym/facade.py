"""The user-facing facade: ``load_scene(path) -> Scene``, ``scene.compile() -> System``.

It ties the layers together (spec -> symbolic -> codegen -> engine) without
letting them leak into each other: the spec layer never sees sympy, the engine
never sees sympy, and a cached compile does not even derive the equations.

**The facade sits above the analysis.**  The compiled system has two levels:

* :class:`gearsym.system.CompiledSystem` (the system layer) is the engine-level object:
  simulate, the flow map, point evaluations, parameters, units, sensitivities.  The
  analysis layer (:mod:`gearsym.analysis`) works on it and imports nothing above it;
* :class:`System` (here) is what :meth:`Scene.compile` returns: the compiled system plus
  the analysis conveniences of DESIGN.md's public surface (:meth:`System.periodic_orbit`),
  which call down into the analysis.

So every import points downwards (spec, symbolic, codegen, engine -> system -> analysis ->
facade -> presentation, CLI), with no exception: the analysis never sees the facade (it
takes a compiled system, or duck-types a scene by its ``compile()``), and the system layer
never sees the analysis.  A :class:`System` pickles as its base does (the copy reloads its
build from the build cache by key).
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Mapping, Sequence
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .catalog import find_scene
from .codegen.cache import BuildCache, build_key
from .codegen.generate import GeneratedModel, build_functions, write_and_compile
from .display import SceneDisplay, SystemDisplay
from .engine.trust import user_cache_dir
from .errors import GearsymError, SpecError
from .spec.model import ModelSpec, load_model
from .spec.scene import ResolvedScene, SceneSpec, load_scene_spec, resolve_scene
from .spec.settings import resolve_settings
from .spec.units import ParameterUnits
from .static import static_state
from .symbolic.model import SymbolicModel
from .system import CompiledSystem

if TYPE_CHECKING:  # pragma: no cover
    from .analysis.linear import ModalAnalysis
    from .analysis.periodic import PeriodicOrbit

#: The settings of :meth:`System.periodic_orbit` that the scene's ``[orbit]`` table may set.
_ORBIT_KEYS = ("segments", "transient", "harmonics", "tol", "rtol", "atol")

_log = logging.getLogger(__name__)


def default_generated_dir(scene_path: str | Path | None = None) -> Path:
    """Where compiled scenes go: ``$GEARSYM_GENERATED`` if set, else the user cache
    (:func:`gearsym.engine.trust.user_cache_dir`: platformdirs' user cache, on Linux
    ``$XDG_CACHE_HOME/gearsym``, else ``~/.cache/gearsym``).

    Never a folder found next to or above the scene: a folder that came from elsewhere
    (a paper's supplement, a colleague's zip, a shared temporary folder) could hold
    planted native code.  A project's own ``generated/`` folder is used only when named
    on purpose (``GEARSYM_GENERATED=generated``, ``compile(generated_dir=...)``,
    ``gearsym cache --dir``).  Whatever the folder, a build is loaded only if this
    user's gearsym signed it (:mod:`gearsym.codegen.cache`).

    Parameters
    ----------
    scene_path
        Unused (the location does not depend on the scene); kept for callers.
    """
    env = os.environ.get("GEARSYM_GENERATED")
    if env:
        return Path(env)
    return user_cache_dir()


class Scene(SceneDisplay):
    """A scene: a model with effects switched on and parameter values.

    ``repr`` is one line (name, model, states, effects, parameters); in Jupyter a scene shows
    its parameters and effects as tables, and ``scene.model`` its equations in LaTeX.

    Parameters
    ----------
    path
        Scene file (``scenes/*.toml``), or the name of a shipped scene (``"kahraman_singh"``;
        ``gearsym models`` lists them).
    effects
        Effect choices overriding the scene's: ``{"backlash": False}``,
        ``{"sliding_friction": "B"}``.
    overrides
        Parameter values overriding the scene's: numbers in the model's declared units, or
        strings with a unit (``"50um"``), see :func:`load_scene`.
    model_spec
        The model, when the caller has already loaded it (default: read the scene's
        ``model`` file).

    Attributes
    ----------
    spec : SceneSpec
    resolved : ResolvedScene
    model : SymbolicModel
        The derived equations (computed on first access).
    """

    def __init__(self, path: str | Path, effects: Mapping[str, bool | str] | None = None,
                 overrides: Mapping[str, float] | None = None, model_spec: ModelSpec | None = None):
        self.path = find_scene(path)
        self.spec: SceneSpec = load_scene_spec(self.path)
        self.model_spec: ModelSpec = model_spec or load_model(self.spec.model_path)
        self.resolved: ResolvedScene = resolve_scene(self.spec, self.model_spec, effects, overrides)

    @property
    def name(self) -> str:
        """Scene name."""
        return self.spec.name

    @cached_property
    def model(self) -> SymbolicModel:
        """The symbolic model (equations of motion, switching, Jacobian, ...)."""
        return SymbolicModel(self.resolved)

    def initial_state(self) -> list[float]:
        """Initial state from the model and scene ``[initial]`` tables (SI units).

        With ``[initial] static = true`` these are the starting guess of the static
        solve that :meth:`compile` does (:mod:`gearsym.static`).

        Returns
        -------
        list of float
            One value per state, in the order of the compiled system's states.
        """
        return [self.resolved.initial[s] for s in self.resolved.state_names()]

    @property
    def dimensionless(self) -> bool:
        """Whether the scene simulates in dimensionless variables (``[simulate] dimensionless``)."""
        return bool(self.spec.simulate.get("dimensionless", False))

    def compile(self, generated_dir: str | Path | None = None, force: bool = False,
                dimensionless: bool | None = None, *, derivatives: bool = False) -> System:
        """Generate C, compile it (or reuse the cached build) and bind it to the engine.

        Parameters
        ----------
        generated_dir
            Root folder of the builds (default: :func:`default_generated_dir`).
        force
            Rebuild even if a cached build exists.
        dimensionless
            Simulate in the dimensionless variables of :meth:`SymbolicModel.dimensionless`
            (time ``tau``, states scaled by their references; the scene's initial state is
            converted); default: the scene's ``[simulate] dimensionless``.
        derivatives
            Build with the parameter derivatives of the sensitivities at once (otherwise
            the system makes that second build on its first sensitivity request).

        Returns
        -------
        System
            The compiled system; its ``x0`` is the scene's initial state, or the static
            equilibrium with ``[initial] static = true`` (:mod:`gearsym.static`).
        """
        if self.resolved.static and self.model_spec.algebraic:
            raise SpecError("the static start does not handle algebraic variables ([constraints]): give "
                            "the initial state", file=self.spec.path, field="initial.static")
        gen = self.generate(generated_dir, force, dimensionless, derivatives=derivatives)
        values = {k: self.resolved.values[k] for k in gen.input_names}
        system = System(gen, values, self.initial_state(), self.spec.simulate, self.name,
                        ParameterUnits.of_model(self.model_spec), self.resolved.rules,
                        {k: v for k, v in self.spec.extra.items() if k in ("orbit", "continue", "map", "runup")},
                        state_units(self.model_spec))
        system.derivative_build = _DerivativeBuild(self, generated_dir, gen.dimensionless)
        if self.resolved.static:  # [initial] static = true: start from the static equilibrium
            system.x0 = static_state(system, *self.resolved.coordinate_states(),
                                     where=(self.spec.path, "initial.static"))
        return system

    def generate(self, generated_dir: str | Path | None = None, force: bool = False,
                 dimensionless: bool | None = None, *, derivatives: bool = False) -> GeneratedModel:
        """Generate and compile, returning the :class:`GeneratedModel` (cache-aware).

        The build is looked up by its key (:func:`gearsym.codegen.cache.build_key`) and
        reused only if it verifies (this user's signature, the key and the SHA-256 of its
        files); otherwise it is built in a private folder under a file lock, signed and
        renamed into place, so concurrent callers get one build.

        Parameters
        ----------
        generated_dir
            Root folder of the builds (default: :func:`default_generated_dir`).
        force
            Rebuild even if a verified build exists (and the shared driver object, too).
        dimensionless
            Generate the dimensionless form (default: the scene's ``[simulate] dimensionless``).
        derivatives
            The build with the parameter derivatives of the sensitivities (its own key).

        Returns
        -------
        GeneratedModel
            Sources, shared object, state and parameter names of the build.

        Raises
        ------
        CompileError
            If the build fails or its folder would lie outside ``generated_dir``; an
            :class:`~gearsym.engine.trust.UntrustedCacheError` (exit code 2) if the cache
            folder is one other users can change, or the signing key is not safe.
        """
        root = Path(generated_dir) if generated_dir else default_generated_dir(self.path)
        try:
            model_text = Path(self.model_spec.path).read_text(encoding="utf-8")
        except OSError as exc:
            raise GearsymError(f"cannot read the model file {self.model_spec.path}: {exc.strerror}") from None
        if dimensionless is None:
            dimensionless = self.dimensionless
        form = self.model_spec.form + ("+dimensionless" if dimensionless else "")
        key, parts = build_key(model_text, self.resolved.effects, form, derivatives=derivatives,
                               data=self.model_spec.data_digest())
        cache = BuildCache(root)
        entry = cache.entry(self.name, key)
        if not force:
            gen, why = cache.check(entry, key)
            if gen is not None:
                _log.info("scene %s: build cache hit, %s", self.name, why)
                return self._reused(gen)
            _log.info("scene %s: build cache miss (%s): building", self.name, why)
        else:
            _log.info("scene %s: rebuilding (force=True) in %s", self.name, entry.directory)
        created = root.absolute()  # the outermost folder this call creates, removed again on failure
        while not created.parent.exists():
            created = created.parent
        created_root = None if created.exists() else created
        try:
            with cache.locked(entry):
                if not force:  # another process may have built it while we waited
                    gen = cache.lookup(entry, key)
                    if gen is not None:
                        _log.info("scene %s: built by another process meanwhile, reusing %s", self.name,
                                  entry.directory)
                        return self._reused(gen)
                if force:  # --force also rebuilds the shared driver object (damaged or not)
                    from .engine import build as engine_build

                    engine_build.driver_object(engine_build.driver_cache_dir(root / ".driver"), force=True)
                t0 = time.perf_counter()
                model = self.model.dimensionless_system() if dimensionless else self.model
                fns = build_functions(model, derivatives=derivatives)
                t_symbolic = time.perf_counter() - t0
                with cache.staging(entry) as staging:
                    gen = write_and_compile(model, fns, staging, entry.directory, self.name, key,
                                            self.resolved.effects, parts)
                    cache.install(staging, entry)
                _log.info("scene %s: built in %.2f s (equations and CasADi functions %.2f s, C sources and compiler %.2f s) "
                          "-> %s", self.name, time.perf_counter() - t0, t_symbolic, gen.compile_seconds,
                          entry.directory)
                return gen
        except BaseException:
            if created_root is not None:  # a failed first build leaves no empty folder behind
                d = root.absolute()
                while True:
                    try:
                        d.rmdir()
                    except OSError:
                        break
                    if d == created_root:
                        break
                    d = d.parent
            raise

    def _reused(self, gen: GeneratedModel) -> GeneratedModel:
        gen.cached = True
        gen.compile_seconds = 0.0
        gen.scene = self.name  # builds are shared by scenes whose names map to one folder
        return gen


class System(SystemDisplay, CompiledSystem):
    """A compiled scene: simulate it, find its periodic orbits, its natural modes.

    Obtained from :meth:`Scene.compile`; not constructed directly.  Everything of
    :class:`gearsym.system.CompiledSystem` (:meth:`simulate`, :meth:`flow`, the parameters
    and their units, the evaluations and sensitivities), plus the analysis conveniences
    (:meth:`periodic_orbit`); :func:`gearsym.continuation` and the maps take it too.

    Parameters
    ----------
    generated
        The compiled model (:meth:`Scene.generate`).
    params
        Values of the run-time parameters (SI units: what the spec layer resolved).
    x0
        The initial state.
    defaults
        The scene's ``[simulate]`` table (``periods``, ``rtol``, ``method``, ...).
    scene_name
        The scene's name (default: the build's).
    units
        The declared units of the parameters (default: every parameter SI).
    rules
        The physical ranges of the parameter values (:mod:`gearsym.spec.rules`).
    settings
        The scene's other settings tables (``orbit``, ``continue``, ``map``), the defaults of
        :meth:`periodic_orbit`, :func:`gearsym.continuation` and the maps.
    state_units
        The unit of time and of every state (:func:`state_units`).
    """

    def natural_modes(self, params: Mapping[str, float] | None = None, **options: Any) -> ModalAnalysis:
        """Natural frequencies and mode shapes about the static equilibrium (``gearsym modes``).

        The linear vibration modes with the mean mesh stiffness
        (:func:`gearsym.analysis.linear.modal_analysis`, the planetary mode types of
        :func:`~gearsym.analysis.linear.classify_planetary` added where they apply); not the
        contact modes of the hybrid system (:meth:`contact_modes`).

        Parameters
        ----------
        params
            Parameter overrides (declared units).
        **options
            Further settings of :func:`~gearsym.analysis.linear.modal_analysis` (``samples``, ...).

        Returns
        -------
        ModalAnalysis
            ``frequencies_hz`` (Hz; cycles per unit time for a model in dimensionless time),
            ``shapes``, ``damping_ratios``, ...; ``to_dataframe()`` / ``to_xarray()``.
        """
        from .analysis.linear import classify_planetary, modal_analysis

        return classify_planetary(modal_analysis(self, params=params, **options))

    def periodic_orbit(self, period: float | None = None, periods: float | None = None,
                       x0: Sequence[float] | None = None, method: str | None = None,
                       params: Mapping[str, float] | None = None, **options: Any) -> PeriodicOrbit:
        """Find a periodic orbit and its Floquet multipliers.

        Delegates to :func:`gearsym.analysis.periodic.periodic_orbit`: ``method="shooting"``
        (Newton on ``phi(T, x0) - x0`` with the engine's variational equations and
        saltation matrices; ``segments=N`` for multiple shooting) or ``"hbm"``
        (harmonic balance with alternating frequency/time; ``harmonics=H`` or grown).

        Parameters
        ----------
        period
            Orbit period (default ``periods`` forcing periods).
        periods
            Number of forcing periods of the orbit, a positive whole number (default: the scene's
            ``[orbit]`` ``periods``, else 1).
        x0
            Initial guess of the state at ``t = 0``.
        method
            ``"shooting"`` or ``"hbm"`` (default: the scene's ``[orbit]`` ``method``, else
            shooting).
        params
            Parameter overrides (declared units).
        **options
            Solver options (``tol``, ``rtol``, ``atol``, ``segments``, ``transient``,
            ``harmonics``, ..., or ``options=`` a :class:`~gearsym.analysis.periodic.ShootingOptions`
            / :class:`~gearsym.analysis.periodic.HarmonicBalanceOptions`); those the scene's
            ``[orbit]`` table sets default to its values (one resolution with ``gearsym orbit``:
            :func:`gearsym.spec.settings.resolve_settings`).

        Returns
        -------
        gearsym.PeriodicOrbit
            ``.x0`` (SI), ``.period`` (the model's time unit), ``.monodromy``, ``.multipliers``,
            ``.stable``, ``.iterations``, ``.residual``, ``.rattle_state``, ...

        Raises
        ------
        ConvergenceError
            The solver did not converge (with its residual history).
        """
        # imported when called: `gearsym simulate` and `gearsym inspect` do not load the solvers
        from .analysis.periodic import periodic_orbit

        s = resolve_settings("orbit", self.settings.get("orbit"), periods=periods, method=method,
                             **{k: options.pop(k) for k in _ORBIT_KEYS if k in options})
        options.update({k: s[k] for k in _ORBIT_KEYS if s[k] is not None})
        return periodic_orbit(self, period=period, periods=s["periods"], x0=x0, method=s["method"], params=params,
                              **options)


class _DerivativeBuild:
    """Makes (or finds) a scene's build with the parameter derivatives, on demand."""

    def __init__(self, scene: Scene, generated_dir: str | Path | None, dimensionless: bool = False):
        self.scene = scene
        self.generated_dir = generated_dir
        self.dimensionless = dimensionless  # the same form as the system's own build

    def __call__(self) -> GeneratedModel:
        return self.scene.generate(self.generated_dir, dimensionless=self.dimensionless, derivatives=True)


def state_units(model: ModelSpec) -> dict[str, str]:
    """The unit of time ``"t"`` and of every state a model can have, as text (coherent SI).

    A coordinate's declared unit (``m``, ``rad``, ``1``: the spec layer accepts coherent SI
    units only), its velocity's that unit per second (``m/s``; the same unit in dimensionless
    time), a reduced coordinate's its declared unit (else its dimension in SI base units), an
    algebraic variable's its declared unit.

    Parameters
    ----------
    model
        The model.

    Returns
    -------
    dict
        Name -> unit text.
    """
    time_unit = model.time_unit or "s"

    def per_time(unit: str) -> str:
        if time_unit == "1":
            return unit
        return "1/s" if unit in ("", "1") else f"{unit}/s"

    out = {"t": time_unit}
    for c in model.coordinates.values():
        out[c.name], out[c.velocity] = c.unit, per_time(c.unit)
    if model.reduction is not None:
        for r in model.reduction.coordinates:
            dims = r.dims if r.dims is not None else model.units.get(r.name)
            unit = r.unit or (dims.si_string() if dims is not None else "")
            out[r.name], out[r.velocity] = unit, per_time(unit)
    for name, a in (model.algebraic or {}).items():
        out[name] = a.unit
    return out


def load_scene(path: str | Path, effects: Mapping[str, bool | str] | None = None,
               **overrides: float | str) -> Scene:
    """Load a scene file.

    Parameters
    ----------
    path
        Scene file, or the name of a shipped scene (:func:`gearsym.catalog.find_scene`).
    effects
        Maps effect names to ``True`` / ``False`` / a variant name, exactly as the
        CLI's ``--effect NAME[=VARIANT]`` / ``--no-effect NAME``.
    **overrides
        Parameter values replacing the scene's, exactly as ``--set NAME=VALUE``: a number in
        the model's declared unit (``b_m=50`` is 50 um if the model declares ``unit = "um"``),
        or a string with a unit (``b_m="50um"``, ``k_m="2e13 N/m"``), converted to the declared
        unit after a check of its dimension.

    Returns
    -------
    Scene

    Examples
    --------
    >>> scene = load_scene("scenes/kahraman_singh.toml", Omega=0.8)   # doctest: +SKIP
    >>> scene = load_scene("scenes/spur_pair_torsional.toml", b_m="0.05mm")  # 50 um  # doctest: +SKIP
    >>> traj = scene.compile().simulate(periods=200)                    # doctest: +SKIP
    """
    return Scene(path, effects, overrides)
