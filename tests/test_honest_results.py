"""Honest results: no periodic orbit is reported where none exists, and a continuation that
cannot advance says so (issue 10 item 8, issue 11 item 3).

The forced linear oscillator ``x'' + 2 zeta x' + x = F cos(Omega t)`` has the exact periodic
orbit ``x = A cos(Omega t) + B sin(Omega t)`` (``A = F (1 - Omega^2) / D``, ``B = 2 zeta Omega F / D``,
``D = (1 - Omega^2)^2 + (2 zeta Omega)^2``) and multipliers ``exp(lambda T)`` with
``lambda = -zeta +- i sqrt(1 - zeta^2)``; undamped at ``Omega = 1`` it has none (the response
grows like ``t sin t``).  The Mathieu equation ``x'' + (a - 2 q cos 2t) x = 0`` has the orbit
``x = 0``, stable with multipliers on the unit circle between the characteristic values
(``scipy.special.mathieu_a`` / ``mathieu_b``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from bad_input._helpers import run_cli
from scipy.linalg import expm
from scipy.special import mathieu_a, mathieu_b

import gearsym
from gearsym.analysis.periodic import isolation
from gearsym.errors import ConvergenceError

OSC = """
[model]
name = "osc"
description = "forced linear oscillator"
time_unit = "1"

[coordinates.x]
unit = "1"
velocity = "v"

[parameters]
zeta = { value = 0.0, meaning = "damping ratio" }
F = { value = 1.0, meaning = "forcing amplitude" }
Omega = { value = 1.0, meaning = "forcing frequency" }

[forcing]
period = "2*pi/Omega"

[elements.mass]
type = "inertia"
coordinate = "x"
value = "1"

[elements.spring]
type = "spring"
deflection = "x"
stiffness = "1"

[elements.damper]
type = "damper"
deflection = "x"
coefficient = "2*zeta"

[elements.force]
type = "force"
coordinate = "x"
value = "F*cos(Omega*t)"

[initial]
x = 0.0
v = 0.0
"""

MATHIEU = """
[model]
name = "mathieu"
description = "Mathieu equation x'' + (a - 2 q cos 2t) x = 0"
time_unit = "1"

[coordinates.x]
unit = "1"
velocity = "v"

[parameters]
a = { value = 1.5, meaning = "a" }
q = { value = 0.5, meaning = "q" }

[forcing]
period = "pi"

[elements.mass]
type = "inertia"
coordinate = "x"
value = "1"

[elements.spring]
type = "spring"
deflection = "x"
stiffness = "a - 2*q*cos(2*t)"

[initial]
x = 0.0
v = 0.0
"""

# two inertias joined by a shaft, nothing to ground: a rigid-body mode (multiplier +1, a family
# of orbits shifted in angle); the orbit exists (the zero-mean torque does no net work)
FREE = """
[model]
name = "free2"
description = "two inertias, free (rigid-body mode)"
time_unit = "1"

[coordinates.a]
unit = "1"
velocity = "va"
[coordinates.b]
unit = "1"
velocity = "vb"

[parameters]
F = { value = 1.0, meaning = "torque amplitude" }
Omega = { value = 1.0, meaning = "forcing frequency" }

[forcing]
period = "2*pi/Omega"

[elements.ma]
type = "inertia"
coordinate = "a"
value = "1"
[elements.mb]
type = "inertia"
coordinate = "b"
value = "2"

[elements.spring]
type = "spring"
deflection = "a - b"
stiffness = "1"

[elements.damper]
type = "damper"
deflection = "a - b"
coefficient = "0.05"

[elements.force]
type = "force"
coordinate = "a"
value = "F*cos(Omega*t)"

[initial]
a = 0.0
b = 0.0
va = 0.0
vb = 0.0
"""


# the oscillator in SI with the forcing speed in rpm
OSC_RPM = """
[model]
name = "osc_rpm"
description = "forced oscillator, speed in rpm"
time_unit = "s"

[coordinates.x]
unit = "m"
velocity = "v"

[parameters]
m = { value = 1.0, unit = "kg", meaning = "mass" }
k = { value = 1.0, unit = "N/m", meaning = "stiffness" }
c = { value = 0.1, unit = "N*s/m", meaning = "damping" }
F = { value = 1.0, unit = "N", meaning = "force amplitude" }
n = { value = 3.0, unit = "rpm", meaning = "speed" }

[forcing]
period = "2*pi/n"

[elements.mass]
type = "inertia"
coordinate = "x"
value = "m"

[elements.spring]
type = "spring"
deflection = "x"
stiffness = "k"

[elements.damper]
type = "damper"
deflection = "x"
coefficient = "c"

[elements.force]
type = "force"
coordinate = "x"
value = "F*cos(n*t)"

[initial]
x = 0.0
v = 0.0
"""


def _write(folder: Path, name: str, model: str, params: str = "") -> Path:
    (folder / f"{name}.toml").write_text(model)
    scene = folder / f"{name}_scene.toml"
    scene.write_text(f'[scene]\nname = "{name}"\nmodel = "{name}.toml"\n'
                     + (f"[parameters]\n{params}\n" if params else ""))
    return scene


@pytest.fixture(scope="module")
def work(tmp_path_factory) -> tuple[Path, Path]:
    """(folder with the scenes, build cache)."""
    d = tmp_path_factory.mktemp("honest")
    gen = d / "gen"
    _write(d, "osc", OSC)
    _write(d, "mathieu", MATHIEU)
    _write(d, "free2", FREE)
    return d, gen


@pytest.fixture(scope="module")
def osc(work):
    d, gen = work
    return gearsym.load_scene(d / "osc_scene.toml").compile(generated_dir=gen)


@pytest.fixture(scope="module")
def mathieu(work):
    d, gen = work
    return gearsym.load_scene(d / "mathieu_scene.toml").compile(generated_dir=gen)


def _cli(work, *args: str):
    d, gen = work
    return run_cli([str(a) for a in args], d, gen)


def _exact_orbit(zeta: float, F: float, Omega: float) -> tuple[np.ndarray, np.ndarray]:
    D = (1 - Omega**2) ** 2 + (2 * zeta * Omega) ** 2
    A, B = F * (1 - Omega**2) / D, 2 * zeta * Omega * F / D
    lam = np.array([-zeta + 1j * math.sqrt(1 - zeta**2), -zeta - 1j * math.sqrt(1 - zeta**2)])
    return np.array([A, Omega * B]), np.exp(lam * 2 * math.pi / Omega)


# ------------------------------------------------------------------ no orbit at an undamped resonance
@pytest.mark.parametrize("method", ["shooting", "hbm"])
def test_undamped_resonance_is_not_a_converged_orbit(work, osc, method):
    # failed before: exit 0, converged and stable, x0 ~ 1e9 (shooting) / 1e33 (hbm)
    r = _cli(work, "orbit", "osc_scene.toml", "--method", method, "--json")
    assert r.returncode == 1, (r.stdout[-500:], r.stderr)
    assert r.stdout == ""
    err = r.stderr.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert "no isolated periodic orbit" in err and "+1" in err and "resonance" in err
    with pytest.raises(ConvergenceError, match="no isolated periodic orbit"):
        osc.periodic_orbit(method=method)
    if method == "shooting":
        o = osc.periodic_orbit(raise_on_failure=False)
        assert not o.converged and "no isolated periodic orbit" in o.info["failure"]
        assert np.max(np.abs(o.x0)) < 1e4  # the state was never moved by noise / noise
        assert not o.info["isolation"]["isolated"]


def test_a_converged_residual_at_an_undamped_resonance_is_no_orbit(work):
    """The backlash oscillator without damping, forced at its resonance, with a backlash of 1e-9
    (linear for any amplitude that matters): Newton reaches a residual below tol at |x0| ~ 1e8,
    the periodic orbit of the integrator's numerical damping.  Before: exit 0, "converged",
    neutral, with only info["isolation"] saying it is not isolated."""
    root = Path(__file__).resolve().parents[1]
    scene = root / "scenes" / "kahraman_singh.toml"
    sets = ("--set", "zeta=0", "--set", "Omega=1", "--set", "eps=0", "--set", "b=1e-9")
    r = _cli(work, "orbit", scene, *sets, "--json")
    assert r.returncode == 1, (r.stdout[-500:], r.stderr)
    assert r.stdout == "" and "Traceback" not in r.stderr
    assert "no isolated periodic orbit" in r.stderr and "is not an orbit" in r.stderr
    ks = gearsym.load_scene(scene).compile(generated_dir=work[1])
    params = {"zeta": 0.0, "Omega": 1.0, "eps": 0.0, "b": 1e-9}
    o = ks.periodic_orbit(params=params, raise_on_failure=False)
    assert not o.converged and not o.info["isolation"]["isolated"]
    assert o.info["relative_residual"] <= 100 * o.info["tol"]  # Newton's own test was met (the noise rule)
    assert "does not determine" in o.info["failure"]
    # the same scene damped (zeta 0.05) or detuned (Omega 0.7: not 1/k either, where the free
    # oscillation has the forcing period too and the orbit is again not isolated) converges
    for change in ({"zeta": 0.05}, {"Omega": 0.7}):
        o = ks.periodic_orbit(params={**params, **change})
        assert o.converged and o.info["isolation"]["isolated"]


@pytest.mark.parametrize("zeta, Omega, accuracy", [(1e-3, 1.0, 1e-7), (1e-6, 1.0, 1e-4), (0.0, 1.001, 1e-7),
                                                   (0.05, 0.7, 1e-7)])
@pytest.mark.parametrize("method", ["shooting", "hbm"])
def test_damped_and_detuned_orbits_still_converge(osc, zeta, Omega, accuracy, method):
    # lightly damped at resonance (amplitude F / (2 zeta) up to 5e5) and undamped off resonance;
    # at zeta = 1e-6 shooting's orbit is only as accurate as (monodromy error) / |mu - 1| ~ 1e-5
    x_ref, mu_ref = _exact_orbit(zeta, 1.0, Omega)
    o = osc.periodic_orbit(method=method, params={"zeta": zeta, "Omega": Omega}, x0=[0.0, 0.0])
    assert o.converged
    scale = np.max(np.abs(x_ref))
    np.testing.assert_allclose(o.x0, x_ref, rtol=0, atol=accuracy * scale)
    mu = o.multipliers[np.argsort(o.multipliers.imag)]
    np.testing.assert_allclose(mu, mu_ref[np.argsort(mu_ref.imag)], rtol=0, atol=1e-7)
    assert o.info["isolation"]["isolated"]


@pytest.mark.parametrize("a", [None, 1.5, 2.5])
@pytest.mark.parametrize("method", ["shooting", "hbm"])
def test_mathieu_zero_orbit_in_stable_intervals_converges(mathieu, a, method):
    # multipliers ON the unit circle but not at +1 (a = a0(q) + 0.01: next to +1); independent
    # reference for the stable intervals: scipy's characteristic values
    q = 0.5
    a = float(mathieu_a(0, q)) + 0.01 if a is None else a
    stable = (mathieu_a(0, q) < a < mathieu_b(1, q)) or (mathieu_a(1, q) < a < mathieu_b(2, q))
    assert stable
    o = mathieu.periodic_orbit(method=method, params={"a": a})
    assert o.converged and np.all(o.x0 == 0)
    np.testing.assert_allclose(np.abs(o.multipliers), 1.0, rtol=0, atol=1e-8)
    assert o.info["isolation"]["isolated"]
    assert np.min(np.abs(o.multipliers - 1)) > 1e-3


def test_rigid_body_family_converges_and_trivial_directions_are_excluded(work):
    # a semi-definite model (handled further by the trains branch): its orbits form a family
    # shifted along the rigid-body mode; the orbit converges and does not drift along it
    d, gen = work
    system = gearsym.load_scene(d / "free2_scene.toml").compile(generated_dir=gen)
    for method in ("shooting", "hbm"):
        o = system.periodic_orbit(method=method, x0=[0, 0, 0, 0], transient=0) if method == "shooting" \
            else system.periodic_orbit(method=method)
        assert o.converged
        assert np.max(np.abs(o.x0)) < 10  # before: a = -3330 (a step along the null direction)
        # the residual is that of a true orbit
        tr = system.simulate(periods=1, x0=o.x0, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(tr.x_final, o.x0, rtol=0, atol=1e-8)
    # not isolated (multiplier +1 of the rigid-body mode), but isolated outside the trivial
    # directions: the design for semi-definite models (rigid-body angle and speed)
    M = o.monodromy
    assert not isolation(M, None, 1e-11).isolated
    rigid = np.array([[1.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 1.0]]).T
    assert isolation(M, None, 1e-11, trivial=rigid).isolated
    o2 = system.periodic_orbit(x0=o.x0, transient=0, trivial=rigid)
    assert o2.converged and o2.info["isolation"]["isolated"]


# ------------------------------------------------------------------ continuation must advance
def test_continue_at_undamped_resonance_stops_incomplete(work):
    # failed before: 5000 points stuck at Omega = 1.00000000009, exit 0 (56 s of CPU measured);
    # --max-points 400 only bounds the cost of the old behaviour
    r = _cli(work, "continue", "osc_scene.toml", "--param", "Omega", "--from", "0.6", "--to", "1.4",
             "--json", "--no-progress", "--max-points", "400")
    assert r.returncode == 1, r.stderr
    data = json.loads(r.stdout)
    assert data["complete"] is False
    assert "does not advance" in data["stop_reason"] and "resonance" in data["stop_reason"]
    assert len(data["points"]) < 300
    assert 0.99 < data["stop_value"] < 1.0
    assert "stopped before the end of the range" in r.stderr and "Traceback" not in r.stderr


@pytest.mark.parametrize("zeta", [1e-2, 1e-4])
def test_continuation_through_a_damped_resonance_covers_the_range(osc, zeta):
    br = gearsym.continuation(osc, "Omega", 0.6, 1.4, params={"zeta": zeta}, detect=False, progress=False)
    assert br.complete and br.stop_reason.startswith("reached Omega = 1.4")
    # the peak F / (2 zeta sqrt(1 - zeta^2)) at Omega = sqrt(1 - 2 zeta^2), to the branch's resolution
    peak = 1 / (2 * zeta * math.sqrt(1 - zeta**2))
    assert abs(np.max(br.max) / peak - 1) < 0.02
    j = int(np.argmax(br.max))
    x_ref, _ = _exact_orbit(zeta, 1.0, br.values[j])
    np.testing.assert_allclose(br.points[j].x0, x_ref, rtol=0, atol=1e-5 * peak)


def test_continue_zero_orbit_with_default_tolerances(work):
    # failed before: exit 2 "tolerances must be positive (atol=0.0)" (the default atol scaled
    # with the state, zero on x = 0)
    r = _cli(work, "continue", "mathieu_scene.toml", "--param", "a", "--from", "1.0", "--to", "3.0", "--json",
             "--no-progress")
    assert r.returncode == 0, r.stderr
    data = json.loads(r.stdout)
    assert data["complete"] and data["atol"] > 0
    pd = [b["value"] for b in data["bifurcations"] if b["type"] == "period_doubling"]
    assert len(pd) == 1 and abs(pd[0] - mathieu_a(1, 0.5)) < 1e-6
    # and an explicit --atol is taken
    r = _cli(work, "continue", "mathieu_scene.toml", "--param", "a", "--from", "1.0", "--to", "1.2", "--json",
             "--no-progress", "--atol", "1e-13")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["atol"] == 1e-13


def test_map_with_every_point_failed_exits_1(work):
    # failed before: exit 0 (every point "converged" on the non-existent orbit); with an
    # impossible rtol (now refused up front) a NaN map and a numpy warning
    d, _ = work
    r = _cli(work, "map", "osc_scene.toml", "--x", "Omega", "1", "1", "1", "--y", "F", "1", "1", "1",
             "--method", "shooting", "--workers", "1", "--out", str(d / "map_out"))
    assert r.returncode == 1, r.stderr
    assert "every one of the 1 points of the map failed" in r.stderr and "no isolated" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert not (d / "map_out" / "map.nc").exists()


def test_continue_prints_values_in_the_declared_unit(work):
    # failed before: "... 0.6 .. 0.7 1" (unit '1') and the stop value of an rpm parameter in rad/s
    d, gen = work
    _write(d, "osc_rpm", OSC_RPM)
    r = _cli(work, "continue", "osc_rpm_scene.toml", "--param", "n", "--from", "3", "--to", "4",
             "--no-progress")
    assert r.returncode == 0, r.stderr
    assert "3 .. 4 rpm" in r.stdout and "reached n = 4 rpm" in r.stdout, r.stdout
    r = _cli(work, "continue", "osc_scene.toml", "--param", "Omega", "--from", "0.6", "--to", "0.7",
             "--no-progress", "--set", "zeta=0.05")
    assert r.returncode == 0, r.stderr
    line = r.stdout.splitlines()[0]
    assert "0.6 .. 0.7," in line and "reached Omega = 0.7" in line and " 1," not in line, line


# ------------------------------------------------------------------ the error model of the isolation check
@pytest.mark.parametrize("rtol", [1e-6, 1e-8, 1e-10, 1e-12])
def test_monodromy_error_is_below_the_isolation_threshold(osc, rtol):
    # references: the undamped oscillator over one period at Omega = 1 has M = I exactly; the damped
    # Meissner equation has the exact product of matrix exponentials (Vaishya & Singh eqs. 25-31)
    from gearsym.analysis.periodic._isolation import ERROR_FACTOR, RTOL_FLOOR

    root = Path(__file__).resolve().parents[1]
    meissner = gearsym.load_scene(root / "scenes" / "meissner.toml").compile()
    p = meissner.params
    T, d, zeta, w0, a = p["T"], p["d"], p["zeta"], p["w0"], p["a"]
    Ap = np.array([[0, 1], [-w0**2 * (1 + a), -2 * zeta * w0]])
    Am = np.array([[0, 1], [-w0**2 * (1 - a), -2 * zeta * w0]])
    cases = [(osc, {}, np.eye(2), [1.0, 0.0]), (osc, {}, np.eye(2), [1e3, 0.0]),
             (meissner, {}, expm(Am * (1 - d) * T) @ expm(Ap * d * T), [1.0, 0.0])]
    worst = 0.0
    for system, params, M_ref, x0 in cases:
        M = system.simulate(periods=1, x0=x0, rtol=rtol, atol=rtol * 1e-2, monodromy=True, params=params).monodromy
        err = np.linalg.norm(M - M_ref, 2) / (max(rtol, RTOL_FLOOR) * max(1.0, np.linalg.norm(M_ref, 2)))
        worst = max(worst, err)
    assert worst < ERROR_FACTOR / 2, worst  # a margin of 2 at least under the threshold
