"""Malformed command lines (``gearsym simulate|compile|inspect|bench``): exit 2, a one-line
message naming the option / parameter / value, no traceback, nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest

import gearsym

from ._helpers import KS_SCENE, ROOT, Case, check_case

KS = str(KS_SCENE)
SPUR = str(ROOT / "scenes" / "spur_pair_torsional.toml")


def _out(w: Path) -> str:
    return str(w / "out")


CASES = [
    Case("scene file not found", lambda w: ["simulate", "nope.toml"], ["nope.toml", "scene file not found"]),
    Case("--set without a value", lambda w: ["simulate", KS, "--set", "Omega"], ["--set expects NAME=VALUE", "Omega"]),
    Case("--set not a number", lambda w: ["simulate", KS, "--set", "Omega=fast"], ["--set Omega", "'fast'"]),
    Case("--set infinite value", lambda w: ["simulate", KS, "--set", "Omega=inf"], ["Omega", "non-finite"]),
    Case("--set NaN value", lambda w: ["compile", KS, "--set", "zeta=nan"], ["zeta", "non-finite"]),
    Case("--set unknown parameter", lambda w: ["simulate", KS, "--set", "Omegaa=1", "--out", _out(w)],
         ["unknown parameter 'Omegaa'"]),
    Case("--set negative inertia", lambda w: ["simulate", SPUR, "--set", "J1=-2e-3", "--out", _out(w)],
         ["spur_pair_torsional.toml", "elements.pinion.value", "J1 = -0.002"]),
    Case("--effect that does not exist", lambda w: ["simulate", KS, "--effect", "friction"],
         ["effect 'friction' is not in model 'kahraman_singh'"]),
    Case("--effect variant that does not exist", lambda w: ["compile", KS, "--effect", "backlash=soft"],
         ["'soft' is not a variant of effect 'backlash'"]),
    Case("parameter of a switched-off effect",
         lambda w: ["simulate", KS, "--no-effect", "mesh_stiffness_variation", "--set", "eps=0.3", "--out", _out(w)],
         ["'eps'", "switched-off effect", "mesh_stiffness_variation"]),
    Case("effect requirement switched off", lambda w: ["simulate", KS, "--effect", "contact_damping",
                                                       "--no-effect", "backlash"],
         ["contact_damping", "requires effect 'backlash'"]),
    Case("impossible tolerance: rtol below double precision",
         lambda w: ["simulate", KS, "--rtol", "1e-20", "--out", _out(w)], ["rtol=1e-20", "double precision"], True),
    Case("impossible tolerance: rtol zero", lambda w: ["simulate", KS, "--rtol", "0"],
         ["tolerances must be positive", "rtol=0"], True),
    Case("impossible tolerance: rtol of 5", lambda w: ["simulate", KS, "--rtol", "5", "--out", _out(w)],
         ["rtol=5"], True),
    Case("impossible tolerance: negative atol", lambda w: ["simulate", KS, "--atol=-1e-10"],
         ["atol=-1e-10"], True),
    Case("--x0 of the wrong length", lambda w: ["simulate", KS, "--x0", "1,2,3"], ["x0 must have 2 entries"], True),
    Case("--x0 not numbers", lambda w: ["simulate", KS, "--x0", "1.1,zero"], ["--x0", "'1.1,zero'"]),
    Case("negative --periods", lambda w: ["simulate", KS, "--periods", "-5", "--out", _out(w)],
         ["periods must be positive", "-5"], True),
    Case("NaN --t-end", lambda w: ["simulate", KS, "--t-end", "nan"], ["t_end", "nan"], True),
    Case("--method ida on an explicit model", lambda w: ["simulate", KS, "--method", "ida"], ["ida", "implicit"], True),
    Case("--out is an existing file",
         lambda w: ((w / "taken").write_text("keep me\n"), ["simulate", KS, "--out", str(w / "taken")])[1],
         ["--out", "taken", "not a folder"]),
    Case("inspect a file that is not TOML", lambda w: ["inspect", str(ROOT / "Makefile")],
         ["Makefile", "TOML syntax error"]),
    Case("inspect a folder", lambda w: ["inspect", str(ROOT / "scenes")], ["scenes", "cannot read file"]),
    Case("simulate a model file instead of a scene", lambda w: ["simulate", str(ROOT / "models" / "kahraman_singh.toml")],
         ["kahraman_singh.toml", "this is a model file; give a scene"]),
    Case("bench: --rtols not numbers", lambda w: ["bench", KS, "--rtols", "1e-4,tight", "--out", _out(w)],
         ["--rtols", "'tight'"]),
    Case("bench: impossible tolerance", lambda w: ["bench", KS, "--rtols", "1e-6,1e-20", "--out", _out(w)],
         ["--rtols", "1e-20"]),
    Case("bench: method that does not exist", lambda w: ["bench", KS, "--methods", "gearsym,matlab ode45"],
         ["--methods", "'matlab ode45'"]),
    Case("bench: --out is an existing file",
         lambda w: ((w / "f.json").write_text("{}"), ["bench", KS, "--out", str(w / "f.json")])[1],
         ["--out", "f.json", "not a folder"]),
    Case("bench: negative --periods", lambda w: ["bench", KS, "--periods", "-1", "--out", _out(w)],
         ["--periods", "-1"]),
    Case("bench: effect that does not exist", lambda w: ["bench", KS, "--effect", "friction", "--out", _out(w)],
         ["effect 'friction'"]),
    Case("unknown command", lambda w: ["simulat", KS], ["invalid choice", "simulat"], argparse=True),
    Case("missing scene argument", lambda w: ["simulate"], ["required", "scene"], argparse=True),
    Case("option value of the wrong type", lambda w: ["simulate", KS, "--periods", "many"],
         ["--periods", "invalid float value", "many"], argparse=True),
]


@pytest.fixture(scope="module")
def gen(tmp_path_factory) -> Path:
    """A build cache holding the benchmark scene's default build (cases that fail after compiling)."""
    g = tmp_path_factory.mktemp("gen")
    gearsym.load_scene(KS_SCENE).compile(generated_dir=g)
    return g


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_cli(case: Case, tmp_path: Path, gen: Path):
    check_case(case, tmp_path, gen)
