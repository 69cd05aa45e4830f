"""``--set`` and ``load_scene(**overrides)`` take a number with a unit and convert it to the
declared unit; a plain number is in the declared unit; every error says so and names that unit
(issue 24, item 11: ``--set b_m=50um`` said "not a number" with no hint)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import gearsym
from gearsym.errors import ParameterError

ROOT = Path(__file__).resolve().parents[1]
SPUR = str(ROOT / "scenes" / "spur_pair_torsional.toml")  # b_m in um, k_m in N/m, omega in rad/s


def _si(**overrides) -> dict[str, float]:
    return gearsym.load_scene(SPUR, **overrides).resolved.values


@pytest.mark.parametrize("given,declared", [("50um", 50.0), ("50 um", 50.0), ("0.04mm", 40.0), ("4e-5 m", 40.0),
                                            ("+2.5e+1um", 25.0), ("7", 7.0)])
def test_unit_suffix_is_converted_to_the_declared_unit(given, declared):
    # the SI value equals the one of the same length typed in the declared unit, exactly
    # (no 40.00000000000001 um from 0.04 * 1e-3 / 1e-6)
    assert _si(b_m=given)["b_m"] == _si(b_m=declared)["b_m"]


def test_other_units():
    assert _si(k_m="2e13 N/m")["k_m"] == 2e13
    assert _si(k_m="2e4kN/m")["k_m"] == 2e7
    assert _si(omega="3000 rpm")["omega"] == pytest.approx(3000 * 2 * 3.141592653589793 / 60, rel=1e-15)


@pytest.mark.parametrize("given,words", [
    ("fast", ["'fast' is not a number", "declared unit of 'b_m', um", "50um"]),
    ("50 N", ["'50 N' is [kg*m*s^-2]", "declared in um [m]"]),
    ("50 furlong", ["unknown unit 'furlong'", "declared unit of 'b_m', um"]),
])
def test_api_errors_name_the_declared_unit(given, words):
    with pytest.raises(ParameterError) as info:
        gearsym.load_scene(SPUR, b_m=given)
    for w in words:
        assert w in str(info.value), str(info.value)
    assert str(info.value).startswith("parameter 'b_m': ")


def test_hz_is_not_taken_for_rad_per_s():
    # 1 Hz is 2*pi rad/s, not 1 rad/s: refused rather than converted with the wrong factor
    with pytest.raises(ParameterError, match=r"Hz \(cycles per second\) and angular frequencies .* give the "
                                             r"value in rad/s"):
        gearsym.load_scene(SPUR, omega="3000Hz")


def _cli(*args: str) -> subprocess.CompletedProcess:
    src = str(Path(gearsym.__file__).resolve().parents[1])  # the gearsym under test
    env = dict(os.environ, PYTHONPATH=src + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "gearsym.cli", *args], capture_output=True, text=True, env=env,
                          cwd=src, timeout=300)


def test_cli_set_with_unit():
    r = _cli("inspect", SPUR, "--set", "b_m=0.04mm", "--set", "k_m=2e8 N/m", "--json")
    assert r.returncode == 0, r.stderr
    params = json.loads(r.stdout)["parameters"]
    assert params["b_m"]["value"] == 40.0 and params["k_m"]["value"] == 2e8  # the values in effect


def test_cli_set_errors_name_the_declared_unit():
    r = _cli("inspect", SPUR, "--set", "b_m=fast")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.strip() == ("gearsym: error: --set b_m: 'fast' is not a number (values are in the declared "
                                "unit of 'b_m', um: b_m=50 means 50 um; a number with a unit such as 50um or "
                                "'2e13 N/m' is converted to it)")
    r = _cli("inspect", SPUR, "--set", "b_m=50 N*m")
    assert r.returncode == 2 and "--set b_m: '50 N*m' is [kg*m^2*s^-2] but 'b_m' is declared in um [m]" in r.stderr
