"""The text summary of ``gearsym runup``: units printed after numbers, none for a dimensionless value.

Found by probing: on the dimensionless benchmark oscillator the summary read ``Omega 0.5 -> 1.5 1 in
300 1`` and ``at Omega = 1 1`` (the unit "1" of a dimensionless speed and time printed after the
number), while ``RunupResult``'s repr already drops it.
"""

from __future__ import annotations

import pytest

from gearsym.cli import main


def test_a_dimensionless_run_up_prints_no_unit_one(capsys):
    rc = main(["runup", "kahraman_singh", "--param", "Omega", "--from", "0.5", "--to", "1.5", "--duration", "300",
               "--bins", "20", "--no-progress"])
    assert rc == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert lines[0].startswith("kahraman_singh: Omega 0.5 -> 1.5 in 300, ")
    crossing = [ln for ln in lines if "order 1 crosses mode 0" in ln]
    assert len(crossing) == 1 and crossing[0].endswith("at Omega = 1")  # Omega_n = 1 exactly
    assert " 1 in " not in out and " 1 1" not in out and " 1 (" not in out


@pytest.mark.parametrize("unit", ["rpm"])
def test_a_dimensional_run_up_keeps_its_units(unit, capsys):
    from pathlib import Path

    scene = Path(__file__).parent / "data" / "runup_pair_scene.toml"
    assert main(["runup", str(scene), "--duration", "0.02", "--bins", "4", "--no-modes", "--no-progress"]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith(f"runup_pair: n 5000 -> 11000 {unit} in 0.02 s, ") and first.endswith(" Hz")
