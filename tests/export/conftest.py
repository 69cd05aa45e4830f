"""Shared exports for the export tests: each scene is exported (and its C program built)
once per session into a temporary folder; the scenes themselves compile into the project's
generated/ cache like every other test's."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

import gearsym
from gearsym.export import export_scene

ROOT = Path(__file__).resolve().parents[2]
SCENES = ROOT / "scenes"


def scene_path(name: str) -> Path:
    """Path of a shipped scene."""
    return SCENES / f"{name}.toml"


def make(directory: Path, *args: str) -> subprocess.CompletedProcess:
    """Run ``make`` in an exported C project."""
    return subprocess.run(["make", "-C", str(directory), *args], capture_output=True, text=True)


class Exported:
    """One scene exported as a C project (built) and an FMU."""

    def __init__(self, root: Path, name: str, c: bool = True, fmu: bool = True):
        self.name = name
        self.scene = gearsym.load_scene(scene_path(name))
        self.system = self.scene.compile()
        self.c_dir = root / f"{name}_c" if c else None
        self.fmu = root / f"{name}.fmu" if fmu else None
        self.info = export_scene(self.scene, c_dir=self.c_dir, fmu=self.fmu)
        self.program = None
        if c:
            proc = make(self.c_dir)
            assert proc.returncode == 0, proc.stdout + proc.stderr
            self.program = self.c_dir / self.info["c"]["program"]

    def run(self, *args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
        """Run the exported program."""
        return subprocess.run([str(self.program), *args], capture_output=True, text=True, cwd=cwd)


@pytest.fixture(scope="session")
def export_root(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("export")


@pytest.fixture(scope="session")
def ks(export_root) -> Exported:
    """The benchmark oscillator (kahraman_singh): C program and FMU."""
    return Exported(export_root, "kahraman_singh")


@pytest.fixture(scope="session")
def vs(export_root) -> Exported:
    """Vaishya & Singh Fig. 3 (schedules: rectangular mesh stiffness, friction reversal)."""
    return Exported(export_root, "vaishya_singh_fig3")


@pytest.fixture(scope="session")
def yu(export_root) -> Exported:
    """Yu et al. 6-DOF pair with dynamic and fractal backlash (a bound function, outputs)."""
    return Exported(export_root, "yu_dynamic_D14")


@pytest.fixture(scope="session")
def ts(export_root) -> Exported:
    """The free two-stage train (two meshes, rectangular mesh stiffness schedules): FMU only."""
    return Exported(export_root, "two_stage_train", c=False)
