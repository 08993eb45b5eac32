"""Reports read back from campaign records: summaries, profiles, figures.

* qpbenchmark-style summary per tolerance preset: success rate and shifted
  geometric mean (SGM) of the solve time, failures charged the time limit;
* Dolan–Moré performance profiles ``rho_s(tau)``: the fraction of problems on
  which solver ``s`` is within a factor ``tau`` of the fastest solver
  (a failure counts as an infinite time);
* work–precision data and diagrams: achieved error against time, per solver
  and problem family, from the tolerance sweep.
"""
from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path

import numpy as np

from .tasks import PRESETS

#: Shift of the shifted geometric mean, seconds (qpbenchmark uses 10 ms).
SGM_SHIFT = 0.01
#: Statuses that mean "this problem is not part of the comparison".
EXCLUDED = ("rejected",)


def shifted_geometric_mean(values, shift: float = SGM_SHIFT) -> float:
    """``exp(mean(log(v + shift))) - shift``.

    Parameters
    ----------
    values : array_like
        Non-negative values (times); ``inf`` gives ``inf``.
    shift : float
        Shift ``sh > 0`` damping the weight of tiny values.
    """
    v = np.asarray(values, dtype=np.float64)
    if v.size == 0:
        return math.nan
    return float(np.exp(np.mean(np.log(v + shift))) - shift)


def charged_time(rec: dict) -> float:
    """Time of a run for summaries: its time if successful, else its time limit."""
    if rec["success"] and math.isfinite(rec["time"]):
        return float(rec["time"])
    return float(rec["time_limit"]) if math.isfinite(rec["time_limit"]) else math.inf


def _by_tol(records, tol):
    return [r for r in records if math.isclose(r["tol"], tol, rel_tol=1e-9)
            and r["status"] not in EXCLUDED]


#: Row label of the virtual best Siconos solver (:func:`virtual_best`).
SICONOS_BEST = "siconos:best-of-all"


def virtual_best(records, prefix: str = "siconos:", label: str = SICONOS_BEST) -> list[dict]:
    """The *virtual best solver* of the records whose solver name starts with ``prefix``.

    Per (problem, tolerance): a copy of the fastest successful run among those
    solvers, or — when none succeeded — of the failed run with the smallest
    error, renamed ``label`` (``message`` names the solver it stands for).  What
    a user who always picked the right Siconos solver after the fact would
    get: the yardstick no single solver of the set can beat.  Records of
    :data:`EXCLUDED` statuses and ``unsupported`` runs do not compete.

    Returns
    -------
    list of dict
        One record per (problem, tolerance) at which any such solver ran.
    """
    groups: dict = defaultdict(list)
    for r in records:
        if r["solver"].startswith(prefix) and r["solver"] != label:
            groups[(r["problem"], r["tol"])].append(r)
    out = []
    for rs in groups.values():
        ran = [r for r in rs if r["status"] not in EXCLUDED + ("unsupported",)]
        if not ran:
            continue
        ok = [r for r in ran if r["success"] and math.isfinite(r["time"])]
        if ok:
            pick = min(ok, key=lambda r: r["time"])
        else:
            pick = min(ran, key=lambda r: r["error"] if math.isfinite(r["error"]) else math.inf)
        out.append(dict(pick, solver=label, message=f"{pick['solver']}: {pick['message']}"[:300]))
    return out


def with_virtual_best(records) -> list[dict]:
    """``records`` plus the virtual best Siconos solver's (:func:`virtual_best`) when they
    hold Siconos runs."""
    return list(records) + virtual_best(records)


def summary_table(records, presets=None) -> list[dict]:
    """Success rate and SGM per (preset, solver).

    Every problem present at a preset's tolerance counts for every solver
    run at it: unsupported runs and failures are failures, charged the time
    limit in the SGM.  ``relative_sgm`` divides by the best SGM of the preset.

    Returns
    -------
    list of dict
        Keys ``preset, tol, solver, problems, success, success_rate, sgm_time,
        relative_sgm, unsupported, time_limit, nan``.
    """
    presets = PRESETS if presets is None else presets
    rows = []
    for preset, tol in presets.items():
        recs = _by_tol(records, tol)
        group = defaultdict(list)
        for r in recs:
            group[r["solver"]].append(r)
        block = []
        for solver, rs in sorted(group.items()):
            ok = sum(bool(r["success"]) for r in rs)
            block.append(dict(
                preset=preset, tol=tol, solver=solver, problems=len(rs), success=ok,
                success_rate=ok / len(rs), sgm_time=shifted_geometric_mean([charged_time(r) for r in rs]),
                unsupported=sum(r["status"] == "unsupported" for r in rs),
                time_limit=sum(r["status"] == "time_limit" for r in rs),
                nan=sum(bool(r["nan"]) for r in rs)))
        best = min((b["sgm_time"] for b in block), default=math.nan)
        for b in block:
            b["relative_sgm"] = b["sgm_time"] / best if best and math.isfinite(best) else math.nan
        rows += block
    return rows


def time_table(records, tol: float) -> dict:
    """``problem -> solver -> time`` at ``tol`` (``inf`` when the run did not succeed)."""
    out: dict = defaultdict(dict)
    for r in _by_tol(records, tol):
        out[r["problem"]][r["solver"]] = float(r["time"]) if r["success"] else math.inf
    return dict(out)


def performance_ratios(table: dict, floor: float = 1e-6) -> dict:
    """Dolan–Moré ratios ``t_ps / min_s t_ps`` per solver (list over problems).

    Times are floored at ``floor`` seconds (a 0 s timer reading cannot make
    every other ratio infinite); a problem no solver solves gives ``inf``
    for all.  A solver absent from a problem's row counts as a failure.
    """
    solvers = sorted({s for row in table.values() for s in row})
    ratios = {s: [] for s in solvers}
    for row in table.values():
        best = min((max(t, floor) for t in row.values()), default=math.inf)
        for s in solvers:
            t = row.get(s, math.inf)
            ratios[s].append(max(t, floor) / best if math.isfinite(best) and math.isfinite(t)
                             else math.inf)
    return ratios


def performance_profile(table: dict, taus=None) -> tuple[np.ndarray, dict]:
    """Dolan–Moré performance profile.

    Parameters
    ----------
    table : dict
        ``problem -> solver -> time`` (``inf`` for a failure), e.g. from :func:`time_table`.
    taus : array_like, optional
        Evaluation points ``tau >= 1`` (default: every finite ratio and 1).

    Returns
    -------
    taus : ndarray
    rho : dict
        ``solver -> rho_s(taus)`` with ``rho_s(tau) = |{p : r_ps <= tau}| / |P|``.
    """
    ratios = performance_ratios(table)
    if taus is None:
        finite = [x for v in ratios.values() for x in v if math.isfinite(x)]
        taus = np.unique(np.concatenate([[1.0], finite])) if finite else np.array([1.0])
    taus = np.asarray(taus, dtype=np.float64)
    n = len(table)
    rho = {s: np.array([np.sum(np.asarray(v) <= t) / n for t in taus]) for s, v in ratios.items()}
    return taus, rho


def work_precision_data(records, floor: float = 1e-17) -> dict:
    """Work–precision points per family and solver from a tolerance sweep.

    Returns
    -------
    dict
        ``family -> solver -> list of dict(tol, time, error, solved, runs)``
        sorted by decreasing ``tol``: ``time`` is the SGM of the charged times
        (failures charged the time limit), ``error`` the geometric mean of the
        achieved errors of the runs that returned impulses (floored at
        ``floor``), ``solved`` the number of successful runs.  A point whose
        runs all lack an error is left out.
    """
    groups = defaultdict(list)
    for r in records:
        if r["status"] in EXCLUDED or r["status"] == "unsupported":
            continue
        groups[(r["family"], r["solver"], float(r["tol"]))].append(r)
    out: dict = defaultdict(lambda: defaultdict(list))
    for (fam, solver, tol), rs in groups.items():
        errs = [max(r["error"], floor) for r in rs if math.isfinite(r["error"])]
        if not errs:
            continue
        out[fam][solver].append(dict(
            tol=tol, time=shifted_geometric_mean([charged_time(r) for r in rs]),
            error=float(np.exp(np.mean(np.log(errs)))), solved=sum(bool(r["success"]) for r in rs),
            runs=len(rs)))
    return {f: {s: sorted(v, key=lambda d: -d["tol"]) for s, v in d.items()} for f, d in out.items()}


# ------------------------------------------------------------------ rendering
def _style(solvers):
    """Line style per solver: ours in distinct colours, every Siconos solver a thin grey
    line (one legend entry for all), the virtual best Siconos solver black and dashed."""
    import matplotlib.pyplot as plt
    cmap = plt.get_cmap("tab10")
    marks = "osD^v<>ph*"
    ours = [s for s in solvers if not s.startswith("siconos:")]
    out = {s: dict(color=cmap(i % 10), marker=marks[i % len(marks)], lw=2.0, ls="-", label=s,
                   zorder=3) for i, s in enumerate(ours)}
    grey = [s for s in solvers if s.startswith("siconos:") and s != SICONOS_BEST]
    for i, s in enumerate(grey):
        out[s] = dict(color="0.72", marker=".", lw=0.8, ls="-",
                      label="siconos: each solver" if i == 0 else None, zorder=1)
    if SICONOS_BEST in solvers:
        out[SICONOS_BEST] = dict(color="black", marker="x", lw=2.0, ls="--",
                                 label=f"{SICONOS_BEST} (virtual)", zorder=4)
    return out


def plot_work_precision(records, path, title="Work–precision (tolerance sweep)") -> Path:
    """Achieved error against time, one panel per family, one line per solver."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker  # noqa: F401
    records = with_virtual_best(records)
    data = work_precision_data(records)
    fams = sorted(data)
    style = _style(sorted({r["solver"] for r in records}))
    ncol = min(3, max(1, len(fams)))
    nrow = max(1, math.ceil(len(fams) / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(5.2 * ncol, 4.0 * nrow), squeeze=False)
    for ax, fam in zip(axes.flat, fams):
        for s, pts in sorted(data[fam].items()):
            t = [p["time"] for p in pts]
            e = [p["error"] for p in pts]
            st = style[s]
            ax.plot(t, e, ls=st["ls"], color=st["color"], lw=0.6 * st["lw"], alpha=0.8,
                    zorder=st["zorder"])
            full = [p["solved"] == p["runs"] for p in pts]
            size = 28 if st["zorder"] > 1 else 8
            ax.scatter([x for x, f in zip(t, full) if f], [y for y, f in zip(e, full) if f],
                       color=st["color"], marker=st["marker"], s=size, label=st["label"],
                       zorder=st["zorder"])
            ax.scatter([x for x, f in zip(t, full) if not f], [y for y, f in zip(e, full) if not f],
                       facecolors="none", edgecolors=st["color"], marker=st["marker"],
                       s=size, zorder=st["zorder"], label=None if any(full) else st["label"])
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_title(f"{fam} ({_n_problems(records, fam)} problems)", fontsize=10)
        ax.set_xlabel("time, SGM over problems [s]")
        ax.set_ylabel("achieved Siconos error (geo. mean)")
        ax.grid(True, which="major", alpha=0.3)
    for ax in list(axes.flat)[len(fams):]:
        ax.axis("off")
    return _finish(fig, axes, path, title + " — filled: all runs reached the tolerance, hollow: "
                   "some failed (charged the time limit)", rect=(0, 0.06, 1, 0.96))


def _finish(fig, axes, path, suptitle, rect) -> Path:
    """Shared legend, title and layout; save ``fig`` as PNG at ``path`` and close it."""
    import matplotlib.pyplot as plt
    _figure_legend(fig, axes)
    fig.suptitle(suptitle, fontsize=10)
    fig.tight_layout(rect=rect)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _figure_legend(fig, axes):
    """One legend for the figure, below the panels."""
    handles, labels = [], []
    for ax in axes.flat:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            if lab not in labels and not lab.startswith("_"):
                handles.append(h)
                labels.append(lab)
    if labels:
        fig.legend(handles, labels, loc="lower center", ncol=min(6, len(labels)), fontsize=9,
                   frameon=False)


def _n_problems(records, fam):
    return len({r["problem"] for r in records if r["family"] == fam})


def plot_performance_profiles(records, path, presets=None, title="Performance profiles (time)") -> Path:
    """Dolan–Moré profiles, one panel per preset."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    presets = PRESETS if presets is None else presets
    records = with_virtual_best(records)
    solvers = sorted({r["solver"] for r in records})
    style = _style(solvers)
    fig, axes = plt.subplots(1, len(presets), figsize=(5.2 * len(presets), 4.2), squeeze=False)
    for ax, (preset, tol) in zip(axes.flat, presets.items()):
        table = time_table(records, tol)
        if not table:
            ax.set_title(f"{preset} (tol {tol:.0e}): no runs")
            continue
        taus, rho = performance_profile(table)
        tmax = max(2.0, float(taus[-1]) * 1.5)
        for s, v in sorted(rho.items()):
            x = np.concatenate([taus, [tmax]])
            y = np.concatenate([v, [v[-1]]])
            st = style[s]
            ax.step(x, y, where="post", color=st["color"], label=st["label"], lw=st["lw"],
                    ls=st["ls"], zorder=st["zorder"])
        ax.set_xscale("log", base=2)
        ax.set_xlim(1.0, tmax)
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel(r"$\tau$ (time / best time)")
        ax.set_ylabel(r"$\rho_s(\tau)$")
        ax.set_title(f"{preset}: tol {tol:.0e}, {len(table)} problems", fontsize=10)
        ax.grid(True, alpha=0.3)
    return _finish(fig, axes, path, title + " — fraction of problems solved within a factor tau "
                   "of the fastest solver", rect=(0, 0.1, 1, 0.95))


def _g(x, fmt=".3g"):
    return "—" if x is None or (isinstance(x, float) and not math.isfinite(x)) else format(x, fmt)


def summary_markdown(records, presets=None, title="Solver comparison") -> str:
    """Markdown summary: one table per preset (success rate, SGM, failures), with the
    virtual best Siconos solver as a row of its own (:func:`virtual_best`)."""
    runs = len(records)
    records = with_virtual_best(records)
    rows = summary_table(records, presets)
    lines = [f"# {title}", "",
             f"{len({r['problem'] for r in records})} problems, "
             f"{len({r['solver'] for r in records if r['solver'] != SICONOS_BEST})} solvers, "
             f"{runs} runs. "
             f"Success = Siconos relative error (recomputed by socp_cd.error from the returned r) "
             f"<= tol. SGM = shifted geometric mean of the time (shift {SGM_SHIFT * 1e3:g} ms), "
             f"failures (unsupported problems included) charged the time limit; relative SGM divides "
             f"by the best solver's. 'solved / supported' leaves out the problems a solver "
             f"declares it cannot handle (e.g. proxsuite: 2D Coulomb only; a Siconos solver: "
             f"the problem families it has no driver for). `{SICONOS_BEST}`: per problem, the "
             f"fastest Siconos solver that succeeded (the virtual best solver).", ""]
    for preset, tol in (PRESETS if presets is None else presets).items():
        block = [r for r in rows if r["preset"] == preset]
        if not block:
            continue
        lines += [f"## {preset} accuracy (tol = {tol:.0e})", "",
                  "| solver | success rate | solved | solved / supported | SGM time [s] | relative SGM "
                  "| time limit | unsupported | NaN |",
                  "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for r in sorted(block, key=lambda r: (-r["success_rate"], r["sgm_time"])):
            sup = r["problems"] - r["unsupported"]
            lines.append(f"| {r['solver']} | {100 * r['success_rate']:.1f}% | {r['success']}/{r['problems']} "
                         f"| {r['success']}/{sup} | {_g(r['sgm_time'], '.4g')} | {_g(r['relative_sgm'], '.2f')} | {r['time_limit']} "
                         f"| {r['unsupported']} | {r['nan']} |")
        lines.append("")
        fails = defaultdict(list)
        for r in _by_tol(records, tol):
            if not r["success"] and r["status"] != "unsupported" and r["solver"] != SICONOS_BEST:
                err = f" {r['error']:.0e}" if math.isfinite(r["error"]) else ""
                fails[r["solver"]].append(f"{r['problem']} ({r['status']}{err})")
        if fails:
            lines += [f"Failures at {preset} (status, achieved error):", ""]
            lines += [f"- {s}: " + "; ".join(v) for s, v in sorted(fails.items())]
            lines.append("")
    return "\n".join(lines)


README_BEGIN = "<!-- bench:begin -->"
README_END = "<!-- bench:end -->"


def readme_table(records, presets=None) -> str:
    """Compact table for the README: per solver, ``solved / problems, SGM [s]`` per preset."""
    presets = PRESETS if presets is None else presets
    rows = summary_table(with_virtual_best(records), presets)
    cells = defaultdict(dict)
    for r in rows:
        cells[r["solver"]][r["preset"]] = f"{r['success']}/{r['problems']}, {_g(r['sgm_time'], '.2g')}"
    head = "| solver | " + " | ".join(f"{p} ({t:.0e})" for p, t in presets.items()) + " |"
    order = sorted(cells, key=lambda s: (-sum(r["success"] for r in rows if r["solver"] == s), s))
    lines = [head, "|---|" + "---|" * len(presets)]
    lines += [f"| {s} | " + " | ".join(cells[s].get(p, "—") for p in presets) + " |" for s in order]
    return "\n".join(lines)


def update_readme(readme, records, presets=None) -> bool:
    """Replace the text between ``README_BEGIN`` and ``README_END`` in ``readme``.

    Returns False (and leaves the file alone) when the markers are missing.
    """
    path = Path(readme)
    text = path.read_text()
    a, b = text.find(README_BEGIN), text.find(README_END)
    if a < 0 or b < a:
        return False
    section = (f"{README_BEGIN}\n<!-- generated by `socp-cd bench --readme`: cells are solved / problems, "
               f"shifted geometric mean of time [s] -->\n{readme_table(records, presets)}\n")
    path.write_text(text[:a] + section + text[b:])
    return True


def write_report(records, outdir, title="Solver comparison", presets=None) -> dict:
    """Write ``summary.md``, ``work_precision.png`` and ``performance_profile.png``."""
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    md = outdir / "summary.md"
    md.write_text(summary_markdown(records, presets, title) + "\n")
    return {"summary": md,
            "work_precision": plot_work_precision(records, outdir / "work_precision.png"),
            "performance_profile": plot_performance_profiles(records, outdir / "performance_profile.png",
                                                             presets)}



def read_rows(path, floats=(), ints=(), bools=("solved",)) -> list:
    """Rows of a study's CSV (``csv.DictReader``) with the named fields converted.

    ``floats``/``ints`` are parsed with ``float``/``int``; ``bools`` are True
    when the field reads ``"True"``.  Other fields stay strings.
    """
    import csv
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        for k in floats:
            r[k] = float(r[k])
        for k in ints:
            r[k] = int(r[k])
        for k in bools:
            r[k] = r[k] == "True"
    return rows


def variant_comparison(rows, key: str, variants, time_limit: float) -> dict:
    """Solved counts and shifted geometric mean times of several variants of one solver.

    Parameters
    ----------
    rows : iterable of dict
        One row per (case, variant) with ``"case"``, ``key``, ``"solved"`` (bool)
        and ``"time"`` (seconds).
    key : str
        The row field naming the variant (e.g. ``"policy"``, ``"rho"``).
    variants : sequence
        The variants to compare, in report order.
    time_limit : float
        What an unsolved case is charged at least.

    Returns
    -------
    dict
        ``variant -> {"cases", "solved", "sgm", "sgm_common", "n_common"}``: ``sgm``
        charges unsolved cases ``max(time, time_limit)``; ``sgm_common`` is over
        the cases every variant solves (``n_common`` of them).
    """
    rows = list(rows)
    common = {r["case"] for r in rows if r["solved"]}
    for v in variants:
        common &= {r["case"] for r in rows if r[key] == v and r["solved"]}
    out = {}
    for v in variants:
        rs = [r for r in rows if r[key] == v]
        charged = [r["time"] if r["solved"] else max(r["time"], time_limit) for r in rs]
        both = [r["time"] for r in rs if r["case"] in common]
        out[v] = {"cases": len(rs), "solved": sum(bool(r["solved"]) for r in rs),
                  "sgm": shifted_geometric_mean(charged),
                  "sgm_common": shifted_geometric_mean(both), "n_common": len(both)}
    return out


def variant_comparison_by(rows, group: str, key: str, variants, time_limit: float):
    """:func:`variant_comparison` per value of ``group`` (sorted), then over all rows.

    Yields ``(group_value or "all", variant, stats)``.
    """
    rows = list(rows)
    for g in sorted({r[group] for r in rows}) + ["all"]:
        sub = [r for r in rows if g == "all" or r[group] == g]
        for v, stats in variant_comparison(sub, key, variants, time_limit).items():
            yield g, v, stats


def variant_disagreements(rows, key: str) -> list:
    """Cases some variants solve and others do not: ``[(case, {variant: row}), ...]`` by case."""
    by_case = {}
    for r in rows:
        by_case.setdefault(r["case"], {})[r[key]] = r
    return sorted((cid, d) for cid, d in by_case.items()
                  if len({bool(d[v]["solved"]) for v in d}) > 1)

def emit(lines, out=None) -> str:
    """A report's ``lines`` as one text: printed, and written to ``out`` when given."""
    text = "\n".join(lines) + "\n"
    print(text)
    if out is not None:
        Path(out).write_text(text)
    return text


__all__ = ["emit", "SGM_SHIFT", "shifted_geometric_mean", "charged_time", "read_rows", "variant_comparison", "variant_comparison_by", "variant_disagreements", "summary_table", "time_table",
           "performance_ratios", "performance_profile", "work_precision_data",
           "plot_work_precision", "plot_performance_profiles", "summary_markdown", "write_report",
           "readme_table", "update_readme", "virtual_best", "with_virtual_best", "SICONOS_BEST"]
