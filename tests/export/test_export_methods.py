"""The exported C program offers the registry's integration methods (its table in
gs_export_data.h comes from gearsym.integrators): ``method=adams_fixedpoint`` runs CVODE Adams
with the fixed-point iteration as System.simulate does, and a method not offered for the
model's form exits 2 naming the one to use."""

from __future__ import annotations

import numpy as np


def _read(path):
    return np.genfromtxt(path, delimiter=",", names=True, dtype=None, encoding="utf-8")


def test_program_runs_every_method_of_its_form_as_system_simulate(ks, tmp_path):
    listing = ks.run("--list").stdout
    assert "method = adams\n" in listing
    usage = ks.run("--help").stdout
    assert "method (adams|bdf|ida|adams_fixedpoint)" in usage
    for method in ("adams", "bdf", "adams_fixedpoint"):
        out = tmp_path / f"{method}.csv"
        proc = ks.run(f"method={method}", "periods=20", "n_out=21", "rtol=1e-10", "atol=1e-12", "--out", str(out))
        assert proc.returncode == 0, proc.stderr
        ref = ks.system.simulate(periods=20, n_out=21, rtol=1e-10, atol=1e-12, method=method)
        got = _read(out)
        err = max(np.abs(got["x"] - ref.y[:, 0]).max(), np.abs(got["v"] - ref.y[:, 1]).max())
        assert err < 1e-9, (method, err)  # the same driver and settings: round-off apart
        assert len(np.atleast_1d(_read(tmp_path / f"{method}_events.csv"))) == len(ref.events) > 10


def test_program_refuses_a_method_of_the_other_form(ks):
    proc = ks.run("method=ida", "periods=1")
    assert proc.returncode == 2 and "method=ida needs a model in implicit form" in proc.stderr
    proc = ks.run("method=rk4")
    assert proc.returncode == 2 and "method must be one of adams, bdf, ida, adams_fixedpoint, got 'rk4'" in proc.stderr
