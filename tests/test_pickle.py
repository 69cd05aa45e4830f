"""A compiled System pickles (issue 14): the copy reloads the same build from the build cache
by its key -- verified, never recompiled -- and computes the same numbers; without the build
in the cache the copy is refused with a message naming the build, not rebuilt silently."""

from __future__ import annotations

import pickle
import shutil
from pathlib import Path

import numpy as np
import pytest

import gearsym
from gearsym.errors import GearsymError

ROOT = Path(__file__).resolve().parents[1]


def test_system_round_trip_reloads_the_build_by_key(tmp_path):
    gen_dir = tmp_path / "gen"
    system = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml", Omega=0.8).compile(generated_dir=gen_dir)
    builds = sorted(p.name for p in gen_dir.iterdir())
    so = Path(system.generated.so_path)
    mtime = so.stat().st_mtime_ns
    copy = pickle.loads(pickle.dumps(system))
    assert isinstance(copy, gearsym.System)
    assert copy.generated.build_key == system.generated.build_key and copy.generated.so_path == str(so)
    assert sorted(p.name for p in gen_dir.iterdir()) == builds and so.stat().st_mtime_ns == mtime  # no rebuild
    assert copy.params == system.params and copy.params["Omega"] == 0.8 and np.array_equal(copy.x0, system.x0)
    a = system.simulate(periods=3, params={"Fa": 0.3})
    b = copy.simulate(periods=3, params={"Fa": 0.3})
    assert np.array_equal(a.y, b.y) and [e.t for e in a.events] == [e.t for e in b.events]
    orbit = copy.periodic_orbit()
    assert isinstance(orbit, gearsym.PeriodicOrbit)
    assert np.array_equal(orbit.x0, system.periodic_orbit().x0)

    blob = pickle.dumps(system)
    shutil.rmtree(gen_dir)
    with pytest.raises(GearsymError, match="not in the build cache"):
        pickle.loads(blob)
