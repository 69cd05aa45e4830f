"""``gearsym sweep`` with no forcing period at its values is bad input (exit 2), as for ``map``,
``orbit``, ``simulate`` and ``lyapunov``.

Found by probing: ``sweep kahraman_singh --param zeta ... --set Omega=-1`` ran every value, each
failing with "the forcing period is not finite and positive", and exited 1 (a failed computation),
while ``map`` and the other commands exit 2 for the same input.
"""

from __future__ import annotations

import pytest

from gearsym.cli import main


@pytest.mark.parametrize("argv, where", [
    (["--param", "zeta", "--from", "0.05", "--to", "0.1", "--set", "Omega=-1"], "Omega = -1"),
    (["--param", "Omega", "--from", "-0.5", "--to", "-0.3"], "Omega = -0.5"),
])
def test_a_sweep_without_a_forcing_period_exits_2(tmp_path, capsys, argv, where):
    rc = main(["sweep", "kahraman_singh", *argv, "--n", "2", "--transient", "20", "--samples", "20",
               "--no-lyapunov", "--workers", "1", "--no-progress", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert f"forcing period is not finite and positive at {where}" in err and "bifurcation diagram" in err


def test_a_sweep_with_a_wrong_x0_names_the_option(tmp_path, capsys):
    rc = main(["sweep", "kahraman_singh", "--param", "Omega", "--from", "0.6", "--to", "0.7", "--n", "2",
               "--x0", "1,2,3", "--no-lyapunov", "--workers", "1", "--no-progress", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2 and "--x0: 3 values given, the model has 2 states (x, v)" in err, err
