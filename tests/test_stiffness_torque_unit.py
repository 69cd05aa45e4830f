"""``gearsym stiffness --torque`` takes a unit, as the lengths and Young's modulus do.

Found by probing: ``--torque '340 N*m'`` (the metavar reads ``N*M``) was refused by argparse as
"invalid float value", while ``--module 3mm`` and ``--youngs 206GPa`` take their units.
"""

from __future__ import annotations

import json

import pytest

from gearsym.cli import main

PAIR = ["stiffness", "--z1", "50", "--z2", "50", "--module", "3", "--face-width", "20", "--samples", "16"]


@pytest.mark.parametrize("torque", ["340", "340 N*m", "0.34kN*m", "340000 N*mm"])
def test_the_torque_takes_a_unit(capsys, torque):
    assert main([*PAIR, "--torque", torque, "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    # ISO 6336's line load F_t / b: 340 N m on the 75 mm reference radius, over 20 mm of face width
    assert info["line_load_N_per_mm"] == pytest.approx(340 / 0.075 / 20, rel=1e-12)


@pytest.mark.parametrize("torque, needle", [("340 N", "'N' is not a unit of torque"), ("-5", "positive"),
                                            ("nan", "non-finite")])
def test_a_bad_torque_exits_2_naming_the_option(capsys, torque, needle):
    assert main([*PAIR, "--torque", torque]) == 2
    err = capsys.readouterr().err
    assert "--torque" in err and needle in err, err
