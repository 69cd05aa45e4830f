"""Nothing a continuation finds is dropped, and a branch that stops early says so (issue 24 item 5).

Before: a detected bifurcation whose location failed was dropped, or reported "located" at
the end of a bracket it never narrowed; a branch whose boundary point failed said "reached"
with ``complete = True`` and its last point outside the range; a broad ``except Exception``
turned a failure of the per-mesh rattle states / deflection extrema into an empty summary.

The failures are injected (a corrector that fails inside a bracket, at the boundary, in the
rattle classification); the verdicts are compared with the same continuation without them.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import gearsym
from gearsym.analysis.continuation import _arclength as arclength
from gearsym.analysis.continuation import _corrector as corrector
from gearsym.analysis.continuation import _detection as detection
from gearsym.analysis.periodic import _meshes as meshes
from gearsym.cli import main
from gearsym.errors import ConvergenceError, GearsymError

ROOT = Path(__file__).resolve().parent.parent
KS = ROOT / "scenes" / "kahraman_singh.toml"
RANGE = (0.8, 0.95)  # both folds of the benchmark's response (0.8356, 0.8941) and a grazing (0.8922)


@pytest.fixture(scope="module")
def ks():
    return gearsym.load_scene(KS).compile()


@pytest.fixture(scope="module")
def reference_branch(ks):
    return gearsym.continuation(ks, "Omega", *RANGE, progress=False)


def _failing_inside(monkeypatch):
    """Every corrected point strictly inside a bracket fails (the end points are known)."""
    real = detection._node_at

    def node_at(C, A, B, sigma, sigma_B, cache, row):
        if sigma in cache:
            return real(C, A, B, sigma, sigma_B, cache, row)
        raise ConvergenceError("corrector: injected failure inside the bracket")

    monkeypatch.setattr(detection, "_node_at", node_at)


def test_a_bifurcation_whose_location_fails_is_reported_with_its_bracket(ks, reference_branch, monkeypatch):
    ref = {b.type: [] for b in reference_branch.bifurcations}
    for b in reference_branch.bifurcations:
        ref[b.type].append(b.value)
    assert sorted(ref) == ["fold", "grazing"] and len(ref["fold"]) == 2
    _failing_inside(monkeypatch)
    br = gearsym.continuation(ks, "Omega", *RANGE, progress=False)
    assert br.complete
    got = {}
    for b in br.bifurcations:
        got.setdefault(b.type, []).append(b)
    # the same special points, none dropped, each with the bracket (the parameter values of the
    # two branch points it lies between) of the value located without the failures
    assert {k: len(v) for k, v in got.items()} == {k: len(v) for k, v in ref.items()}
    for kind, bs in got.items():
        for b, value in zip(bs, ref[kind], strict=True):
            assert b.info["located"] is False and "injected failure" in b.info["reason"]
            lo, hi = sorted(b.info["bracket"])
            assert lo < hi
            if kind == "fold":  # a turning point: the parameter is extremal there, beyond both neighbours
                assert min(abs(value - lo), abs(value - hi)) <= hi - lo
            else:
                assert lo <= value <= hi
            assert b.point is br.points[b.index]  # the branch point after the change
    # each branch point once (an unlocated point is a branch point, not a copy of it)
    values = br.values
    assert len(np.unique(values)) == len(values)
    d = br.to_dict()
    assert all(b["located"] is False and len(b["bracket"]) == 2 for b in d["bifurcations"])
    assert all(b.info["located"] is True for b in reference_branch.bifurcations)


def test_cli_prints_the_bracket_of_an_unlocated_bifurcation(monkeypatch, capsys):
    _failing_inside(monkeypatch)
    rc = main(["continue", str(KS), "--param", "Omega", "--from", str(RANGE[0]), "--to", str(RANGE[1]),
               "--no-progress"])
    out = capsys.readouterr().out
    assert rc == 0  # the branch covers its range; the special points are reported, as not located
    lines = [ln for ln in out.splitlines() if "NOT located" in ln]
    assert len(lines) == 3 and all("between the branch points at Omega = " in ln for ln in lines)


def test_a_branch_whose_boundary_point_fails_is_incomplete(ks, monkeypatch, capsys, tmp_path):
    def fail(*a, **kw):
        raise ConvergenceError("corrector: injected failure at the boundary")

    monkeypatch.setattr(arclength, "boundary_node", fail)
    br = gearsym.continuation(ks, "Omega", 0.6, 0.7, progress=False)
    assert not br.complete
    assert "could not be corrected" in br.stop_reason and "injected failure" in br.stop_reason
    assert br.values[-1] > 0.7  # the last point is the one outside the range, and it says so
    rc = main(["continue", str(KS), "--param", "Omega", "--from", "0.6", "--to", "0.7", "--no-progress", "--json"])
    cap = capsys.readouterr()
    assert rc == 1 and json.loads(cap.out)["complete"] is False
    assert "stopped before the end of the range" in cap.err


def test_a_failing_rattle_classification_is_not_an_empty_one(ks, monkeypatch):
    def fail(*a, **kw):
        raise GearsymError("injected failure of the rattle states")

    monkeypatch.setattr(corrector, "mesh_rattle_states", fail)
    with pytest.raises(GearsymError, match="injected failure of the rattle states"):
        gearsym.continuation(ks, "Omega", 0.6, 0.7, progress=False)


def test_a_failing_mesh_summary_is_not_an_empty_one(ks, monkeypatch):
    def fail(*a, **kw):
        raise RuntimeError("injected failure of the mesh extrema")

    monkeypatch.setattr(meshes, "_refined_periodic", fail)
    monkeypatch.setattr(meshes, "mesh_extrema", fail)
    with pytest.raises(RuntimeError, match="injected failure of the mesh extrema"):
        gearsym.continuation(ks, "Omega", 0.6, 0.7, progress=False)


def _passes_it_on(handler) -> bool:
    """Whether a handler hands the exception on: it raises, or the caught object is used (sent to
    the parent process, wrapped, recorded as the failure of that task)."""
    import ast

    if any(isinstance(n, ast.Raise) for n in ast.walk(handler)):
        return True
    return handler.name is not None and any(isinstance(n, ast.Name) and n.id == handler.name
                                            for stmt in handler.body for n in ast.walk(stmt))


def test_no_broad_except_in_the_analysis():
    """No ``except Exception`` / bare ``except`` in gearsym/analysis that swallows what it caught
    (every one was on a result path); a handler that raises or passes the exception on (the
    worker processes send it to the parent) is not a silent drop."""
    import ast

    bad = []
    for path in sorted((Path(gearsym.__file__).parent / "analysis").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ExceptHandler) and (
                    node.type is None or (isinstance(node.type, ast.Name) and node.type.id in ("Exception",
                                                                                             "BaseException"))):
                if not _passes_it_on(node):
                    bad.append(f"{path.name}:{node.lineno}")
    assert not bad, bad
