"""``[tables.NAME.gears]``: the pressure angle takes its unit, like the module.

Found by probing: ``pressure_angle = 20`` (meaning degrees, as ``gearsym stiffness --pressure-angle
20`` does) was read as 20 radians and refused as ``pressure_angle_deg must be < 45, got 1145.92``,
naming only ``tables.k.gears``.  Now a bare number is refused naming the key and the unit to write.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_tables_spec import GEARS, spec_error, write

from gearsym.spec.model import load_model


@pytest.mark.parametrize("angle", ["pressure_angle = 20", 'pressure_angle = "20"', "pressure_angle = 0.35"])
def test_a_pressure_angle_without_a_unit_is_refused_naming_the_key(tmp_path, angle):
    msg = spec_error(write(tmp_path, table=GEARS + angle + "\n", csv=None))
    assert "tables.k.gears.pressure_angle" in msg and '"' in msg and " deg" in msg, msg
    assert "1145" not in msg


def test_a_pressure_angle_in_degrees_or_radians_gives_the_same_table(tmp_path):
    deg = load_model(write(tmp_path / "deg", table=GEARS + 'pressure_angle = "20 deg"\n', csv=None)).tables["k"]
    rad = load_model(write(tmp_path / "rad", table=GEARS + f'pressure_angle = "{math.radians(20.0)!r} rad"\n',
                           csv=None)).tables["k"]
    default = load_model(write(tmp_path / "def", table=GEARS, csv=None)).tables["k"]
    q = np.linspace(0.0, 1.0, 101)[:-1]
    np.testing.assert_allclose(deg(q), default(q), rtol=1e-12)
    np.testing.assert_allclose(rad(q), default(q), rtol=1e-12)
    assert deg.info["pressure_angle_deg"] == pytest.approx(20.0, rel=1e-12)
