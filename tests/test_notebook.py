"""The notebook tour (examples/notebooks/tour.ipynb) runs top to bottom in a Jupyter kernel of this
interpreter, and every display in it is short and readable.

The kernel is this interpreter (a kernel spec written into a temporary folder, so no installed
``python3`` kernel of another environment is picked up); the notebook loads a shipped scene,
shows its equations (``_repr_latex_``), compiles, simulates, plots, finds the periodic orbit,
continues it (with a progress bar), draws a small map, computes the natural modes, runs a
run-up (its HTML card and order tracks), converts results to xarray / pandas and round-trips
one through netCDF.  The cells are tagged with what
they promise: ``html`` (a ``text/html`` output), ``latex`` (``text/latex``), ``gearsym-repr``
(a gearsym object whose text repr is at most :data:`MAX_REPR` characters), ``progress`` (a
progress bar drawn in the notebook).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")

TOUR = Path(__file__).resolve().parents[1] / "examples" / "notebooks" / "tour.ipynb"

#: Any text output (``text/plain``, a stream): at most this many lines and characters.
MAX_LINES, MAX_CHARS = 40, 4000
#: The text repr of a gearsym object.
MAX_REPR = 500
WIDGET = "application/vnd.jupyter.widget-view+json"


@pytest.fixture(scope="module")
def executed(tmp_path_factory: pytest.TempPathFactory):
    """The tour, executed by nbclient in a kernel running ``sys.executable``."""
    from jupyter_client.kernelspec import KernelSpecManager
    from jupyter_client.manager import KernelManager

    tmp = tmp_path_factory.mktemp("notebook")
    spec = tmp / "kernels" / "gearsym-test"
    spec.mkdir(parents=True)
    (spec / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "gearsym (test)", "language": "python",
        "env": {"IPYTHONDIR": str(tmp / "ipython")},
    }), encoding="utf-8")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("JUPYTER_RUNTIME_DIR", str(tmp / "runtime"))
        km = KernelManager(kernel_name="gearsym-test",
                           kernel_spec_manager=KernelSpecManager(kernel_dirs=[str(tmp / "kernels")]))
        nb = nbformat.read(TOUR, as_version=4)
        # a hang guard, not a speed check (the tour takes seconds)
        nbclient.NotebookClient(nb, km=km, timeout=600, resources={"metadata": {"path": str(tmp)}}).execute()
    return nb


def _code_cells(nb):
    return [c for c in nb.cells if c.cell_type == "code"]


def _texts(cell) -> list[str]:
    """Every text a cell shows: text/plain of results and displays, stream text."""
    out = []
    for o in cell.outputs:
        if o.output_type == "stream":
            out.append(o.text)
        elif "text/plain" in o.get("data", {}):
            out.append(o.data["text/plain"])
    return out


def test_the_stored_notebook_has_no_outputs():
    nb = nbformat.read(TOUR, as_version=4)
    nbformat.validate(nb)
    assert [c.outputs for c in _code_cells(nb) if c.outputs] == []
    assert all(c.execution_count is None for c in _code_cells(nb))


def test_the_kernel_runs_this_interpreter(executed):
    # (the tour's first cell imports gearsym; that it ran proves the project is importable there)
    assert executed.cells[1].outputs, "the first code cell shows the scene"


def test_every_text_output_is_short(executed):
    long = []
    for i, cell in enumerate(_code_cells(executed)):
        for text in _texts(cell):
            if text.count("\n") + 1 > MAX_LINES or len(text) > MAX_CHARS:
                long.append((i, text.count("\n") + 1, len(text), text[:200]))
    assert long == []


def test_gearsym_reprs_are_short_and_html_and_latex_are_there(executed):
    cells = _code_cells(executed)
    for tag, mime in (("html", "text/html"), ("latex", "text/latex")):
        tagged = [c for c in cells if tag in c.metadata.get("tags", [])]
        assert tagged, tag
        for c in tagged:
            results = [o for o in c.outputs if o.output_type == "execute_result"]
            assert len(results) == 1 and mime in results[0].data, (tag, c.source)
    reprs = [c for c in cells if "gearsym-repr" in c.metadata.get("tags", [])]
    assert len(reprs) >= 8
    for c in reprs:
        text = next(o for o in c.outputs if o.output_type == "execute_result").data["text/plain"]
        assert len(text) <= MAX_REPR and "object at 0x" not in text, text


def test_the_equations_are_typeset_with_cases(executed):
    cells = [c for c in _code_cells(executed) if "latex" in c.metadata.get("tags", [])]
    model = next(o for o in cells[0].outputs if o.output_type == "execute_result").data["text/latex"]
    assert model.startswith("$$") and "\\ddot{x}" in model and "\\begin{cases}" in model
    assert "g_{\\mathrm{mesh.drive}}" in model  # the switching surfaces
    groups = next(o for o in cells[1].outputs if o.output_type == "execute_result").data["text/latex"]
    assert "\\zeta &= \\frac{c_{m}}{2 \\sqrt{k_{m} m_{e}}}" in groups  # a dimensionless group with its definition


def test_no_warnings_and_a_progress_bar_in_the_notebook(executed):
    cells = _code_cells(executed)
    stderr = [(c.source, o.text) for c in cells for o in c.outputs
              if o.output_type == "stream" and o.name == "stderr" and "progress" not in c.metadata.get("tags", [])]
    assert stderr == []
    (cont,) = [c for c in cells if "progress" in c.metadata.get("tags", [])]
    # stderr is no terminal in a kernel: the bar is there because the code runs in a notebook
    assert any(WIDGET in o.get("data", {}) or (o.output_type == "stream" and "continuation in Omega" in o.text)
               for o in cont.outputs)


def test_plots_and_the_netcdf_round_trip(executed):
    cells = _code_cells(executed)
    images = [o for c in cells for o in c.outputs if "image/png" in o.get("data", {})]
    assert len(images) >= 2
    last = "".join(_texts(cells[-1]))
    assert "orbit.nc" in last and "stability asymptotically_stable" in last
