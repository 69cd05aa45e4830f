"""Run-up mesh orders beyond the angle samples' Nyquist order are refused, not silently NaN.

Found by probing: ``gearsym runup spur_pair_torsional ... --orders 1000`` exited 0 with orders 1..7
(16 samples per mesh cycle resolve orders below 8) and 993 all-NaN order tracks, drawn as 1000
legend entries in orders.png (and a matplotlib tight_layout warning).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import gearsym
from gearsym.cli import main
from gearsym.errors import ParameterError

SCENE = Path(__file__).parent / "data" / "runup_pair_scene.toml"  # one mesh, 25 teeth


@pytest.fixture(scope="module")
def system():
    return gearsym.load_scene(SCENE).compile()


def test_orders_up_to_the_nyquist_order_are_all_tracked(system):
    res = gearsym.runup(system, duration=0.02, settle=0, bins=4, modes=False, orders=7, samples_per_period=16,
                        progress=False)
    assert res.order_amplitude.shape[:2] == (1, 7)
    assert np.all(np.isfinite(res.order_amplitude))  # 7 < 16 / 2: every order is one DFT bin below Nyquist
    assert [p["order"] for p in res.peaks()] == list(range(1, 8))


@pytest.mark.parametrize("orders, spp, top", [(8, 16, 7), (1000, 16, 7), (5, 10, 4)])
def test_orders_beyond_the_nyquist_order_are_refused(system, orders, spp, top):
    with pytest.raises(ParameterError, match=rf"orders={orders}: .*resolve mesh orders up to {top} "):
        gearsym.runup(system, duration=0.02, settle=0, bins=4, modes=False, orders=orders, samples_per_period=spp,
                      progress=False)


def test_cli_orders_beyond_nyquist_exit_2(capsys):
    assert main(["runup", str(SCENE), "--duration", "0.02", "--orders", "1000", "--no-modes", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "orders=1000" in err and "--samples-per-period" in err and "up to 7" in err
