"""Presentation of a work-precision run: the text table, the figure and the output files."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["format_table", "plot_work_precision", "write_outputs"]


def format_table(data: Mapping[str, Any]) -> str:
    """Plain-text table: one block per rtol, one row per method."""
    lines = [f"{data['case']}: {data['reference']['kind']} reference (floor {data['reference']['floor']:.1e})"
             + (f", error horizon {data['divergence']['horizon_periods']:.3g} periods (chaotic)"
                if data["divergence"]["chaotic"] and data["divergence"]["horizon_periods"] else "")]
    chaotic = bool(data["divergence"]["chaotic"])
    head = f"  {'method':24s} {'best ms':>10s} {'x gearsym':>9s} {'error':>9s} {'events':>7s}" + (
        f" {'stat dev':>9s}" if chaotic else "")
    for rtol in data["rtols"]:
        lines.append(f" rtol {rtol:g}")
        lines.append(head)
        for r in (r for r in data["results"] if r["rtol"] == rtol):
            if "best_s" not in r:
                lines.append(f"  {r['method']:24s} {r.get('failed') or r.get('skipped')}")
                continue
            ratio = r.get("ratio_to_gearsym")
            ev = r.get("n_events")
            sd = f" {r['statistics_deviation']['mean_rms']:9.1e}" if chaotic else ""
            lines.append(f"  {r['method']:24s} {r['best_s'] * 1e3:10.3f} "
                         f"{(f'{ratio:.1f}' if ratio else '-'):>9s} {r['error']:9.1e} "
                         f"{(str(ev) if ev is not None else '-'):>7s}{sd}")
    par = data.get("pareto", {})
    bad = {k: v for k, v in par.get("by_rtol", {}).items() if not v["on_front"]}
    lines.append(" gearsym on the Pareto front at every tolerance" if not bad else
                 " gearsym dominated at rtol " + "; ".join(f"{k} by {', '.join(v['dominated_by'][:2])}"
                                                           for k, v in bad.items()))
    return "\n".join(lines)


def plot_work_precision(data: Mapping[str, Any], path: str | Path) -> None:
    """Log error vs log wall time, one line per method (lower left is better)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5.2))
    floor = float(data["reference"]["floor"])
    styles = {"gearsym": ("C3", "o", 2.2), "gearsym (bdf)": ("C1", "s", 1.6),
              "scipy DOP853 + events": ("C2", "D", 1.4)}
    others = [f"C{i}" for i in (0, 4, 5, 6, 7, 8, 9)]
    k = 0
    for m in dict.fromkeys(r["method"] for r in data["results"]):
        rows = [r for r in data["results"] if r["method"] == m and "best_s" in r]
        if not rows:
            continue
        if m in styles:
            color, marker, lw = styles[m]
        else:
            color, marker, lw = others[k % len(others)], "^v<>Px"[k % 6], 1.0
            k += 1
        ls = "-" if rows[0]["events"] else "--"
        x = [r["best_s"] for r in rows]
        y = [max(r["error"], 1e-17) for r in rows]
        ax.plot(x, y, ls, color=color, marker=marker, lw=lw, ms=5, label=m)
        for r, xx, yy in zip(rows, x, y):
            if r["rtol"] in (rows[0]["rtol"], rows[-1]["rtol"]) and r["gearsym"]:
                ax.annotate(f"{r['rtol']:.0e}", (xx, yy), fontsize=7, xytext=(4, 2), textcoords="offset points")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.axhline(floor, color="0.6", lw=0.8, ls=":")
    ax.text(ax.get_xlim()[1], floor, "reference floor ", fontsize=7, va="bottom", ha="right", color="0.4")
    ax.set_xlabel("wall time of one integration, best of repeats [s] (compile excluded)")
    ax.set_ylabel("max normalised state error on the output grid")
    sub = data["reference"]["kind"]
    if data["divergence"]["chaotic"] and data["divergence"]["horizon_periods"]:
        sub += f", error over the first {data['divergence']['horizon_periods']:.3g} periods (chaotic)"
    per = f"{data['periods']:g} periods" if data.get("periods") else f"t_end {data['t_end']:g}"
    ax.set_title(f"{data['case']}: {per}, {sub} reference", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2, title="solid: located events; dashed: steps over the kinks",
              title_fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)



def write_outputs(result: Mapping[str, Any], out_dir: str | Path, stem: str) -> list[str]:
    """Write ``stem.json`` and ``stem.png`` into ``out_dir`` (created now), each atomically."""
    from ..files import atomic_path, write_json

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    jpath, ppath = out / f"{stem}.json", out / f"{stem}.png"
    with atomic_path(ppath) as tmp:
        plot_work_precision(result["case"], tmp)
    write_json(jpath, result)
    return [str(jpath), str(ppath)]


def _json_default(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        return o.item()
    return str(o)
