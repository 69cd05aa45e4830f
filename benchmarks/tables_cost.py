"""The cost of a table: a 64-sample table against the same function written by hand.

A 1-DOF mesh with backlash (``m x'' + c x' + k(phase) f(x) = F``, contact loss every period)
whose mesh stiffness is a 64-sample table over the mesh phase, interpolated

* ``linear``  -- against a hand-written ``piecewise_cycle`` on a 64-segment schedule whose
  values are the same lines ``y_j + s_j (phase - x_j)`` (what a user wrote before tables);
* ``cubic``   -- against a ``piecewise_cycle`` of the same cubic polynomials;
* ``fourier`` -- against a hand-written ``fourier`` excitation with the same 32 harmonics;

and a spring whose force is a 64-knot table over the deflection (``outside = "hold"``: 64
switching surfaces), against the same law written as one ``Piecewise`` of 64 conditions on
the state, and a smooth cubic force law (no surfaces) for scale.

For each pair: steps, scheduled breaks, events, right-hand-side evaluations and operations
(``gs_rhs``), the wall time of a 200-period simulation (best of ``--repeats``) and the ratio
table / hand-written, and the largest difference of the two trajectories (relative to the
range).  A table should cost what the hand-written expression of the same smoothness costs.

Run: ``python benchmarks/tables_cost.py [--periods 200] [--repeats 7] [--out out/bench]``.
Writes ``tables_cost.json``.
"""

from __future__ import annotations

import argparse
import json
import platform
import tempfile
from pathlib import Path

import numpy as np

import gearsym
from gearsym.spec.interpolants import cubic_pieces, fourier_fit

N = 64
T_M = 4.4e-4
XK = np.arange(N) / N
VALS = 1e8 * (1 + 0.3 * np.cos(2 * np.pi * XK) + 0.1 * np.sin(4 * np.pi * XK)
              + 0.05 * np.tanh(20 * np.sin(2 * np.pi * XK)))
FX = np.linspace(-20e-6, 43e-6, N)                       # a force law over the deflection (m)
FV = 1e8 * FX + 2e17 * FX ** 3                           # hardening (N)

HEAD = f'''[model]
name = "NAME"
[coordinates.x]
unit = "m"
velocity = "v"
[parameters]
m = {{ value = 0.5, unit = "kg" }}
c = {{ value = 700.0, unit = "N*s/m" }}
F = {{ value = 500.0, unit = "N" }}
b = {{ value = 10.0, unit = "um" }}
T_m = {{ value = {T_M}, unit = "s" }}
k_u = {{ value = 1.0, unit = "N/m" }}
F_u = {{ value = 1.0, unit = "N" }}
x_u = {{ value = 1.0, unit = "m" }}
F_a = {{ value = 1500.0, unit = "N" }}
[schedules.mesh]
period = "T_m"
[forcing]
period = "T_m"
[elements.mass]
type = "inertia"
coordinate = "x"
value = "m"
[initial]
x = 1.5e-5
'''
MESH = '''[elements.load]
type = "force"
coordinate = "x"
value = "F"
[elements.mesh]
type = "mesh"
deflection = "x"
damping = "c"
backlash = "b"
stiffness = STIFFNESS
'''


def _f(v: float) -> str:
    return repr(float(v))


def _table(kind: str) -> str:
    tol = "\ntolerance = 0.0" if kind == "fourier" else ""
    return (MESH.replace("STIFFNESS", '"k(mesh_phase)"') + f'[tables.k]\nunit = "N/m"\ndomain = "phase"\n'
            f'x = [{", ".join(map(_f, XK))}]\nvalues = [{", ".join(map(_f, VALS))}]\n'
            f'interpolation = "{kind}"{tol}\n')


def _by_hand(kind: str) -> str:
    """The same function written without tables."""
    if kind == "fourier":
        f = fourier_fit(XK, VALS, 1.0, 0.0)
        cos = ", ".join(f'"k_u*{_f(a)}"' for a in f.cos)
        sin = ", ".join(f'"k_u*{_f(b)}"' for b in f.sin)
        return MESH.replace("STIFFNESS", f'{{ type = "fourier", frequency = "2*pi/T_m", mean = "k_u*{_f(f.mean)}", '
                                         f'cos = [{cos}], sin = [{sin}] }}')
    if kind == "linear":
        xs, ys = np.append(XK, 1.0), np.append(VALS, VALS[0])
        coefs = [((ys[j + 1] - ys[j]) / (xs[j + 1] - xs[j]), ys[j]) for j in range(N)]
    else:
        coefs = cubic_pieces(XK, VALS, 1.0).coefs
    values = []
    for j, c in enumerate(coefs):
        u = f"(phase - {_f(XK[j])})"
        expr = _f(c[0])
        for a in c[1:]:
            expr = f"({expr})*{u} + {_f(a)}"
        values.append(f'"k_u*({expr})"')
    breaks = ", ".join(_f(x) for x in XK[1:])
    return (MESH.replace("STIFFNESS", f'{{ type = "piecewise_cycle", schedule = "knots", values = [{", ".join(values)}] }}')
            + f'[schedules.knots]\nperiod = "T_m"\nbreaks = [{breaks}]\n')


def _force_law(kind: str) -> str:
    """A spring whose force is a 64-knot table over the deflection, the same law as one Piecewise, or a
    smooth cubic law (numbers carry their units through F_u = 1 N and x_u = 1 m)."""
    extra = ""
    if kind == "table":
        law = "Fs(x)"
        extra = (f'[tables.Fs]\nunit = "N"\ndomain = "m"\nx = [{", ".join(map(_f, FX))}]\n'
                 f'values = [{", ".join(map(_f, FV))}]\n')
    elif kind == "piecewise":
        pieces = [f"({_f(FV[0])}, x/x_u < {_f(FX[0])})"]
        for j in range(N - 1):
            s = (FV[j + 1] - FV[j]) / (FX[j + 1] - FX[j])
            pieces.append(f"({_f(FV[j])} + {_f(s)}*(x/x_u - {_f(FX[j])}), x/x_u < {_f(FX[j + 1])})")
        pieces.append(f"({_f(FV[-1])}, True)")
        law = f"F_u*Piecewise({', '.join(pieces)})"
    else:
        law = "F_u*(1e8*(x/x_u) + 2e17*(x/x_u)**3)"
    return f'[equations.x]\nforce = "F + F_a*cos(2*pi*t/T_m) - c*v - {law}"\n' + extra


def _model(name: str, body: str) -> str:
    return HEAD.replace("NAME", name) + body


def build(folder: Path, name: str, body: str):
    """Compile one model (a scene with its defaults)."""
    (folder / f"{name}.toml").write_text(_model(name, body))
    (folder / f"{name}_s.toml").write_text(f'[scene]\nmodel = "{name}.toml"\n')
    return gearsym.load_scene(folder / f"{name}_s.toml").compile()


def measure(systems: dict, periods: int, repeats: int) -> dict[str, dict]:
    """Every system simulated ``repeats`` times, round-robin (so that a slow moment of a shared machine
    hits all of them alike); the best time of each."""
    times: dict[str, list[float]] = {k: [] for k in systems}
    last = {}
    for _ in range(repeats):
        for name, system in systems.items():
            tr = system.simulate(periods=periods, x0=[1.5e-5, 0.0], rtol=1e-8, atol=1e-14)
            times[name].append(tr.stats["wall_s"])
            last[name] = tr
    out = {}
    for name, system in systems.items():
        tr, gen = last[name], system.generated
        out[name] = {"name": name, "wall_best_s": min(times[name]), "wall_median_s": float(np.median(times[name])),
                     "n_steps": tr.stats["n_steps"], "n_rhs": tr.stats["n_rhs"], "n_breaks": tr.stats["n_breaks"],
                     "n_events": tr.stats["n_events"], "n_surfaces": gen.nsw, "n_ops_rhs": gen.n_ops["gs_rhs"],
                     "n_ops_jac": gen.n_ops["gs_jac"], "_x": np.stack([tr["x"], tr["v"]], axis=1)}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--periods", type=int, default=200)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--out", default="out/bench")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    pairs = []
    with tempfile.TemporaryDirectory(prefix="gearsym-tables-") as tmp:
        folder = Path(tmp)
        cases = [(f"table_{k}", _table(k), f"hand_{k}", _by_hand(k)) for k in ("linear", "cubic", "fourier")]
        cases.append(("table_force_law", _force_law("table"), "hand_force_law", _force_law("piecewise")))
        systems = {}
        for tname, tbody, hname, hbody in cases:
            systems[tname] = build(folder, tname, tbody)
            systems[hname] = build(folder, hname, hbody)
        systems["smooth_force_law"] = build(folder, "smooth_force_law", _force_law("smooth"))
        res = measure(systems, a.periods, a.repeats)
    for tname, _, hname, _ in cases:
        t, h = res[tname], res[hname]
        xt, xh = t.pop("_x"), h.pop("_x")
        diff = np.max(np.abs(xt - xh), axis=0) / np.ptp(xh, axis=0)
        pairs.append({"table": t, "by_hand": h, "wall_ratio": t["wall_best_s"] / h["wall_best_s"],
                      "steps_ratio": t["n_steps"] / h["n_steps"], "max_state_difference_over_range": diff.tolist()})
        print(f"{tname:16s} {t['n_steps']:7d} steps {t['n_breaks']:6d} breaks {t['n_events']:5d} events "
              f"{t['n_ops_rhs']:5d} ops {t['wall_best_s'] * 1e3:7.2f} ms | {hname:15s} {h['n_steps']:7d} steps "
              f"{h['n_ops_rhs']:5d} ops {h['wall_best_s'] * 1e3:7.2f} ms | time ratio {pairs[-1]['wall_ratio']:.3f}, "
              f"state difference / range {max(diff):.1e}")
    smooth = res["smooth_force_law"]
    smooth.pop("_x")
    result = {"periods": a.periods, "repeats": a.repeats, "samples": N, "machine": platform.platform(),
              "pairs": pairs, "smooth_force_law": smooth}
    (out / "tables_cost.json").write_text(json.dumps(result, indent=1))
    print(f"smooth cubic force law (no surfaces): {smooth['n_steps']} steps, {smooth['wall_best_s'] * 1e3:.2f} ms")
    print(f"wrote {out / 'tables_cost.json'}")


if __name__ == "__main__":
    main()
