"""Output files are written atomically and JSON is strict (issue 10 items 9, 10); ``simulate(t_out=)``
ends at the last output time (issue 10 item 11).

Each bug test failed before (``git stash``): an interrupted ``trajectory.npz`` stayed behind half
written (``np.load`` rejects it), ``orbit --method hbm --json`` printed ``NaN``, and
``simulate(t_out=...)`` integrated to the scene's horizon (200 forcing periods).
"""

from __future__ import annotations

import errno
import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

import gearsym
from gearsym import cli
from gearsym.errors import ParameterError
from gearsym.files import atomic_path, save_figure, to_json, write_json

ROOT = Path(__file__).resolve().parents[1]
KS = ROOT / "scenes" / "kahraman_singh.toml"
MEISSNER = ROOT / "scenes" / "meissner.toml"


def _strict(text: str):
    def bad(name):
        raise ValueError(f"not JSON: {name}")

    return json.loads(text, parse_constant=bad)


@pytest.fixture(scope="module")
def gen(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("gen")


# ------------------------------------------------------------------ JSON
def test_to_json_has_no_nan_or_infinity():
    obj = {"a": math.nan, "b": [math.inf, -math.inf, 1.5], "c": np.float64("nan"), "d": np.array([1.0, np.nan]),
           "e": 1 + 2j, "f": np.array([1 - 1j]), "g": np.int64(3), "h": np.bool_(True), "i": (Path("x"), None)}
    back = _strict(to_json(obj))
    assert back == {"a": None, "b": [None, None, 1.5], "c": None, "d": [1.0, None], "e": [1.0, 2.0],
                    "f": [[1.0, -1.0]], "g": 3, "h": True, "i": ["x", None]}


def test_cli_json_is_strict(capsys, monkeypatch, gen):
    # the harmonic-growth record of harmonic balance starts with change = NaN
    monkeypatch.setenv("GEARSYM_GENERATED", str(gen))
    assert cli.main(["orbit", str(MEISSNER), "--method", "hbm", "--json", "--set", "zeta=0.05"]) == 0
    out = capsys.readouterr().out
    data = _strict(out)
    assert data["harmonic_growth"][0]["change"] is None


# ------------------------------------------------------------------ atomic files
def _half_writer(real):
    """A ``numpy.savez_compressed`` that writes part of the file, then fails like a full disk."""

    def fake(file, *args, **kwargs):
        fh = open(file, "wb") if isinstance(file, (str, Path)) else file  # noqa: SIM115
        fh.write(b"PK\x03\x04 half of a zip file")
        fh.flush()
        raise OSError(errno.ENOSPC, "No space left on device")

    return fake


def test_interrupted_npz_leaves_no_partial_file(tmp_path, monkeypatch, gen):
    system = gearsym.load_scene(MEISSNER).compile(generated_dir=gen)
    tr = system.simulate(periods=2)
    target = tmp_path / "trajectory.npz"
    tr.save_npz(target)
    good = target.read_bytes()
    monkeypatch.setattr(np, "savez_compressed", _half_writer(np.savez_compressed))
    with pytest.raises(OSError, match="No space left"):
        tr.save_npz(target)
    assert target.read_bytes() == good  # the previous, complete file
    assert sorted(p.name for p in tmp_path.iterdir()) == ["trajectory.npz"]  # no temporary left
    with pytest.raises(OSError):
        tr.save_npz(tmp_path / "new.npz")
    assert not (tmp_path / "new.npz").exists()
    monkeypatch.undo()
    np.testing.assert_array_equal(np.load(target)["y"], tr.y)


def test_ctrl_c_while_simulate_writes_its_out_folder(tmp_path, monkeypatch, gen):
    # the CLI path: Ctrl-C in the middle of writing trajectory.npz -> exit 130, no trajectory.npz
    monkeypatch.setenv("GEARSYM_GENERATED", str(gen))

    def interrupted(file, *args, **kwargs):
        fh = open(file, "wb") if isinstance(file, (str, Path)) else file  # noqa: SIM115
        fh.write(b"PK\x03\x04 half")
        fh.flush()
        raise KeyboardInterrupt

    monkeypatch.setattr(np, "savez_compressed", interrupted)
    out = tmp_path / "out"
    assert cli.main(["simulate", str(MEISSNER), "--periods", "3", "--out", str(out)]) == 130
    assert not (out / "trajectory.npz").exists()
    assert [p.name for p in out.iterdir() if p.name.startswith(".")] == []


@pytest.mark.parametrize("exc", [KeyboardInterrupt, OSError])
def test_atomic_path_keeps_the_old_file(tmp_path, exc):
    target = tmp_path / "orbit.json"
    write_json(target, {"x0": [1.0, 2.0]})
    with pytest.raises(exc), atomic_path(target) as tmp:
        tmp.write_text('{"x0": [3.0, ')
        raise exc()
    assert _strict(target.read_text()) == {"x0": [1.0, 2.0]}
    assert [p.name for p in tmp_path.iterdir()] == ["orbit.json"]


def test_interrupted_figure_leaves_no_partial_png(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    target = tmp_path / "time_history.png"

    class Boom(Exception):
        pass

    real = fig.savefig

    def half(fh, **kw):
        real(fh, **kw)
        raise Boom

    fig.savefig = half
    with pytest.raises(Boom):
        save_figure(fig, target, dpi=50)
    assert list(tmp_path.iterdir()) == []
    fig.savefig = real
    save_figure(fig, target, dpi=50)
    plt.close(fig)
    assert target.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# ------------------------------------------------------------------ simulate(t_out=...)
def test_t_out_without_t_end_ends_at_the_last_output_time(gen):
    system = gearsym.load_scene(MEISSNER).compile(generated_dir=gen)
    p = system.params
    T, d, zeta, w0, a = p["T"], p["d"], p["zeta"], p["w0"], p["a"]
    t_out = np.linspace(0.0, 1.25 * T, 41)
    tr = system.simulate(t_out=t_out, rtol=1e-11, atol=1e-13)
    assert tr.t[-1] == t_out[-1]
    np.testing.assert_array_equal(tr.x_final, tr.y[-1])  # before: the state at t = 50 T
    # independent reference: the exact piecewise-constant propagation (Vaishya & Singh eqs. 25-31)
    Ap = np.array([[0, 1], [-w0**2 * (1 + a), -2 * zeta * w0]])
    Am = np.array([[0, 1], [-w0**2 * (1 - a), -2 * zeta * w0]])
    x_ref = expm(Ap * 0.25 * T) @ expm(Am * (1 - d) * T) @ expm(Ap * d * T) @ system.x0
    np.testing.assert_allclose(tr.x_final, x_ref, rtol=0, atol=1e-8)
    assert tr.stats["n_breaks"] <= 3  # breakpoints at d T, T (and 1.25 T): not 100 of them


def test_output_grid_limit_refused_before_integrating(gen):
    system = gearsym.load_scene(MEISSNER).compile(generated_dir=gen)
    with pytest.raises(ParameterError, match="output grid"):
        system.simulate(periods=1e12)
    with pytest.raises(ParameterError, match="max_steps"):
        system.simulate(periods=1e7, n_out=2)
    with pytest.raises(ParameterError, match="t_out must"):
        system.simulate(t_out=[0.0, 2.0, 1.0])
