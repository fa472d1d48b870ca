"""Figures of a campaign: metric distributions, force percentile bands, outcome rates.

Each ``plot_*`` function draws onto a given Axes (a new one if None) and returns it; each
``*_figure`` function lays out the panels ``acc sweep`` writes (``metrics.png``,
``failure_rate.png``, ``force_bands.png``) and returns the Figure.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from numpy.typing import NDArray

from acc.campaigns.report import value_codes

#: Readable axis labels (with units) of the columns the sweep figures show.
COLUMN_LABELS: dict[str, str] = {
    "rms_error_N": "RMS force error [N]",
    "iae_N_s": "IAE of the force [N s]",
    "ise_N2_s": "ISE of the force [N² s]",
    "peak_force_N": "peak force [N]",
    "max_overshoot_pct": "largest overshoot [%]",
    "machining_time_s": "machining time [s]",
    "productivity_gain_pct": "productivity gain [%]",
    "max_abs_following_error_mm": "largest |following error| [mm]",
    "rms_following_error_mm": "RMS following error [mm]",
    "iae_mm_s": "IAE of the following error [mm s]",
    "max_abs_current_A": "largest |current| [A]",
    "max_abs_contour_error_mm": "largest |contour error| [mm]",
    "iae_contour_mm_s": "IAE of the contour error [mm s]",
    "controller": "controller kind",
    "position_controller": "position controller",
    "contour_controller": "contour controller",
    "radial_depths_mm": "radial depths [mm]",
    "workpiece.radial_depth_mm": "radial depths [mm]",
    "force_process.gain_multiplier": "process-gain multiplier (material) [-]",
}
#: Unit suffixes of column names (longest first) and the unit they stand for.
_UNIT_SUFFIXES = (
    ("_N_per_mm_min", "N/(mm/min)"), ("_N2_s", "N² s"), ("_N_s", "N s"), ("_mm_min", "mm/min"),
    ("_rad_s", "rad/s"), ("_Nm_s_rad", "N m s/rad"), ("_mm_s", "mm/s"), ("_pct", "%"),
    ("_deg", "deg"), ("_mm", "mm"), ("_um", "um"), ("_Hz", "Hz"), ("_N", "N"), ("_A", "A"),
    ("_V", "V"), ("_s", "s"), ("_m", "m"),
)
#: Outcome flags of a run that the outcome figure counts, and what each panel says it counts.
OUTCOMES: dict[str, str] = {
    "failed": "failed (diverged or stopped)",
    "oscillating": "oscillating (sustained limit cycle)",
    "overload": "overload (force above its limit)",
}


def column_label(name: str) -> str:
    """A readable axis label of a summary column, its unit in brackets.

    Known columns (:data:`COLUMN_LABELS`) get their label; another ``section.key_unit``
    column gets ``section.key [unit]`` from its unit suffix; a column without one is
    returned unchanged.
    """
    if name in COLUMN_LABELS:
        return COLUMN_LABELS[name]
    for suffix, unit in _UNIT_SUFFIXES:
        if name.endswith(suffix) and len(name) > len(suffix):
            return f"{name[: -len(suffix)]} [{unit}]"
    return name


def _axes(ax: Axes | None) -> Axes:
    if ax is None:
        _, ax = plt.subplots()
    return ax


def _text(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float | np.floating) else str(value)


def distinct_colors(labels: Sequence[str]) -> dict[str, Any]:
    """One colour per label, all different: ``tab10`` up to 10 labels, ``tab20`` up to 20,
    then evenly spaced hues."""
    n = len(labels)
    if n <= 10:
        colors = [plt.get_cmap("tab10")(i) for i in range(n)]
    elif n <= 20:
        colors = [plt.get_cmap("tab20")(i) for i in range(n)]
    else:
        colors = [plt.get_cmap("hsv")(i / n) for i in range(n)]
    return dict(zip(labels, colors, strict=True))


def grouping_column(
    summary: Mapping[str, NDArray], by: str, swept: Sequence[str], most: int = 8
) -> str | None:
    """The swept column that splits the runs of each ``by`` group further: the first of
    ``swept`` with 2 to ``most`` distinct values that is not ``by`` itself (nor a copy of it).
    None if there is none."""
    groups, _ = value_codes(summary[by])
    for key in swept:
        if key not in summary or key == by:
            continue
        codes, values = value_codes(summary[key])
        distinct = len(values)
        if not 2 <= distinct <= most:
            continue
        if len(np.unique(groups * distinct + codes)) == distinct:
            continue  # the same partition as ``by`` (e.g. controller.kind beside controller)
        return key
    return None


def plot_metric_distribution(
    summary: Mapping[str, NDArray],
    metric: str,
    ax: Axes | None = None,
    by: str = "controller",
    within: str | None = None,
    colors: Mapping[str, Any] | None = None,
) -> Axes:
    """Box plot of one metric over the completed runs: one group of boxes per value of
    ``by`` (the controller kind by default), one box per value of ``within`` in each group.

    Parameters
    ----------
    summary : mapping of str to ndarray, shape (runs,)
        Columns of a sweep summary (:func:`acc.campaigns.sweep.read_summary`).
    metric : str
        Column to show (its unit is in its name; the axis gets :func:`column_label`).
    ax : matplotlib Axes or None
    by : str
        Column that groups the runs along the x axis.
    within : str or None
        Column that splits each group (one coloured box per value; a legend names them, see
        :func:`metrics_figure`).  None: one box per group.
    colors : mapping of str to colour, optional
        ``within`` value -> colour (default :func:`distinct_colors`).

    Returns
    -------
    matplotlib Axes
    """
    ax = _axes(ax)
    groups = sorted(set(summary[by].tolist()))
    subs = sorted(set(summary[within].tolist())) if within is not None else [None]
    colors = dict(colors or distinct_colors([_text(s) for s in subs]))
    values = np.asarray(summary[metric], dtype=float)
    ok = ~np.asarray(summary["failed"], bool) & np.isfinite(values)
    width = 0.8 / len(subs)
    for j, sub in enumerate(subs):
        data, pos = [], []
        for i, g in enumerate(groups):
            sel = (summary[by] == g) & ok
            if sub is not None:
                sel &= summary[within] == sub
            data.append(values[sel])
            pos.append(i + (j - (len(subs) - 1) / 2) * width)
        face = colors[_text(sub)] if sub is not None else "white"
        stats = [box_stats(x) for x in data]
        del data  # (a box's values are not needed once its statistics are taken)
        ax.bxp(stats, positions=pos, widths=0.85 * width, showfliers=True,
               patch_artist=True, manage_ticks=False,
               boxprops={"facecolor": face, "alpha": 0.85, "linestyle": "solid"},
               medianprops={"color": "k"},
               flierprops={"markersize": 3, "markeredgecolor": "0.4"})
    ax.set_xticks(np.arange(len(groups)), [_text(g) for g in groups],
                  rotation=30 if len(groups) > 3 else 0, ha="right" if len(groups) > 3 else
                  "center")
    ax.set_xlim(-0.6, len(groups) - 0.4)
    ax.set_xlabel(column_label(by))
    ax.set_ylabel(column_label(metric))
    ax.grid(True, axis="y", alpha=0.3)
    if not np.any(ok):  # an empty panel says why instead of showing a bare axis
        ax.set_yticks([])
        ax.text(0.5, 0.5, "no completed run has a value\n(NaN: e.g. no run finished the part)",
                transform=ax.transAxes, ha="center", va="center", color="0.35")
    return ax


def box_stats(x: NDArray, whis: tuple[float, float] = (5.0, 95.0)) -> dict[str, Any]:
    """A box plot's statistics of finite values, as ``matplotlib.cbook.boxplot_stats``
    takes them with whiskers at percentiles ``whis`` (the same numbers), with one sorted copy
    of the values instead of five (a box of 1e6 runs: 8 MB instead of 40).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Finite values.
    whis : (float, float)
        Percentiles of the whiskers' ends [%].

    Returns
    -------
    dict
        ``med``, ``q1``, ``q3``, ``iqr``, ``mean``, ``cilo``, ``cihi``, ``whislo``,
        ``whishi`` and ``fliers`` (the values beyond the whiskers), for ``Axes.bxp``.
    """
    x = np.asarray(x, dtype=float).ravel()
    if len(x) == 0:
        return {"fliers": np.array([]), **dict.fromkeys(
            ("mean", "med", "q1", "q3", "iqr", "cilo", "cihi", "whislo", "whishi"), np.nan)}
    q1, med, q3, lo, hi = np.percentile(x, [25.0, 50.0, 75.0, *whis])
    iqr = q3 - q1
    notch = 1.57 * iqr / np.sqrt(len(x))
    # the whiskers end at the most extreme values inside the percentiles, never inside the box
    whishi = np.max(x, where=x <= hi, initial=-np.inf)
    whislo = np.min(x, where=x >= lo, initial=np.inf)
    whishi = q3 if whishi < q3 else whishi
    whislo = q1 if whislo > q1 else whislo
    return {"mean": np.mean(x), "med": med, "q1": q1, "q3": q3, "iqr": iqr,
            "cilo": med - notch, "cihi": med + notch, "whislo": whislo, "whishi": whishi,
            "fliers": np.concatenate([x[x < whislo], x[x > whishi]])}


def metrics_figure(
    summary: Mapping[str, NDArray],
    metrics: Sequence[str],
    by: str = "controller",
    swept: Sequence[str] = (),
) -> Figure:
    """One panel per metric, the runs grouped by ``by`` and split by a swept column.

    When every run has the same ``by`` value (a gain or feed sweep of one lab) the runs are
    grouped by the first swept column with a few values instead; inside each group, one box
    per value of the next swept column with a few values (:func:`grouping_column`), named in
    the figure's legend.  Whiskers span the 5th to 95th percentile.

    Parameters
    ----------
    summary : mapping of str to ndarray, shape (runs,)
    metrics : sequence of str
        Float columns, one panel each.
    by : str
        Column that groups the runs.
    swept : sequence of str
        The campaign's swept keys (summary columns).

    Returns
    -------
    Figure
    """
    if len(set(summary[by].tolist())) == 1:
        by = next((k for k in swept if k in summary
                   and 2 <= len(set(summary[k].tolist())) <= 12), by)
    within = grouping_column(summary, by, swept)
    subs = sorted(set(summary[within].tolist())) if within else []
    colors = distinct_colors([_text(s) for s in subs])
    boxes = len(set(summary[by].tolist())) * max(len(subs), 1)
    ncols = 1 if boxes > 12 else min(len(metrics), 2)
    nrows = -(-len(metrics) // ncols)
    fig, axes = plt.subplots(
        nrows, ncols, squeeze=False, layout="constrained", sharex=True,
        figsize=(max(6.0, min(16.0, 2.0 + 0.35 * boxes)) if ncols == 1 else 10.0,
                 2.9 * nrows + (0.6 if within else 0.0)),
    )
    for k, (ax, m) in enumerate(zip(axes.ravel(), metrics, strict=False)):
        plot_metric_distribution(summary, m, ax=ax, by=by, within=within, colors=colors)
        if k < len(metrics) - ncols:  # the x axis is shared: its labels on the last row only
            ax.set_xlabel("")
            ax.tick_params(labelbottom=False)
    for ax in axes.ravel()[len(metrics):]:
        ax.set_visible(False)
    what = "completed runs (box: quartiles and median; whiskers: 5-95 %)"
    if within:
        handles = [Patch(facecolor=colors[_text(s)], edgecolor="k", label=_text(s)) for s in subs]
        fig.legend(handles=handles, title=f"{column_label(within)}; {what}",
                   loc="outside upper center", ncol=min(len(subs), 6), fontsize=8,
                   title_fontsize=8)
    else:
        fig.suptitle(what[0].upper() + what[1:], fontsize=9)
    return fig


def _bins(x: NDArray, bins: int) -> tuple[NDArray[np.int_], list[str]]:
    """Bin index of each value and the bins' labels (each distinct value when there are at
    most ``bins``, else ``bins`` equal bins over the range)."""
    values = np.unique(x[np.isfinite(x)])
    if len(values) > bins:
        edges = np.linspace(values[0], values[-1], bins + 1)
        index = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, bins - 1)
        return index, [f"{lo:.3g}-{hi:.3g}" for lo, hi in zip(edges[:-1], edges[1:],
                                                             strict=True)]
    return np.searchsorted(values, x), [f"{v:g}" for v in values]


def outcome_counts(
    summary: Mapping[str, NDArray], parameter: str, flag: str = "failed", bins: int = 10,
    by: str = "controller",
) -> tuple[list[str], list[str], NDArray[np.int_], NDArray[np.int_]]:
    """How many runs of each group and parameter bin have an outcome flag.

    Parameters
    ----------
    summary : mapping of str to ndarray, shape (runs,)
    parameter : str
        Numeric column; with more than ``bins`` distinct values it is binned.
    flag : str
        Boolean column counted (``failed``, ``oscillating``, ``overload``).
    bins : int
    by : str
        Column that groups the runs.

    Returns
    -------
    groups : list of str, length G
    bin_labels : list of str, length B
    flagged : ndarray of int, shape (G, B)
        Runs with the flag.
    runs : ndarray of int, shape (G, B)
        Runs in the cell.
    """
    x = np.asarray(summary[parameter], dtype=float)
    index, labels = _bins(x, bins)
    groups = sorted(set(summary[by].tolist()))
    hit = np.asarray(summary[flag], bool)
    flagged = np.zeros((len(groups), len(labels)), int)
    runs = np.zeros_like(flagged)
    for i, g in enumerate(groups):
        rows = summary[by] == g
        for j in range(len(labels)):
            sel = rows & (index == j)
            runs[i, j] = np.count_nonzero(sel)
            flagged[i, j] = np.count_nonzero(sel & hit)
    return [_text(g) for g in groups], labels, flagged, runs


def plot_failure_rate(
    summary: Mapping[str, NDArray],
    parameter: str,
    ax: Axes | None = None,
    bins: int = 10,
    by: str = "controller",
    flag: str = "failed",
) -> Axes:
    """Share of runs with an outcome flag, per group and swept parameter value: a table of
    cells coloured by the share, each cell written ``flagged/runs``.

    Parameters
    ----------
    summary : mapping of str to ndarray, shape (runs,)
    parameter : str
        Numeric column; with more than ``bins`` distinct values it is binned.
    ax : matplotlib Axes or None
    bins : int
    by : str
        Column that groups the runs (one row each).
    flag : str
        Boolean column counted (:data:`OUTCOMES`): ``failed`` by default.

    Returns
    -------
    matplotlib Axes
        Its title says what is counted and how many runs of all have it.
    """
    ax = _axes(ax)
    groups, labels, flagged, runs = outcome_counts(summary, parameter, flag, bins, by)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.where(runs > 0, flagged / np.maximum(runs, 1), np.nan)
    ax.imshow(100.0 * share, cmap="Reds", vmin=0.0, vmax=100.0, aspect="auto",
              interpolation="nearest")
    for (i, j), n in np.ndenumerate(runs):
        if n:
            ax.text(j, i, f"{flagged[i, j]}/{n}", ha="center", va="center", fontsize=7,
                    color="white" if flagged[i, j] > 0.6 * n else "k")
    ax.set_xticks(np.arange(len(labels)), labels, rotation=40 if len(labels) > 4 else 0,
                  ha="right" if len(labels) > 4 else "center", fontsize=7)
    ax.set_yticks(np.arange(len(groups)), groups, fontsize=7)
    ax.set_xlabel(column_label(parameter))
    ax.set_ylabel(column_label(by))
    total = int(np.count_nonzero(np.asarray(summary[flag], bool)))
    ax.set_title(f"{OUTCOMES.get(flag, flag)}: {total} of {len(summary[flag])} runs",
                 fontsize=9)
    return ax


def failure_rate_figure(
    summary: Mapping[str, NDArray], parameter: str, by: str = "controller", bins: int = 10
) -> Figure:
    """One :func:`plot_failure_rate` panel per outcome flag the summary carries
    (:data:`OUTCOMES`: failed, and oscillating and overload runs, which need not fail)."""
    flags = [f for f in OUTCOMES if f in summary]
    groups = len(set(summary[by].tolist()))
    fig, axes = plt.subplots(
        1, len(flags), squeeze=False, layout="constrained",
        figsize=(3.3 + 3.2 * len(flags), 1.8 + 0.3 * groups),
    )
    for ax, flag in zip(axes[0], flags, strict=True):
        plot_failure_rate(summary, parameter, ax=ax, bins=bins, by=by, flag=flag)
    for ax in axes[0][1:]:
        ax.set_ylabel("")
    fig.suptitle("Runs with each outcome per group and parameter value (cell: runs with it / "
                 "runs; colour: share)", fontsize=9)
    return fig


def _band_labels(
    traces: Mapping[str, NDArray], summary: Mapping[str, NDArray], by: str,
    profile: str | None,
) -> tuple[NDArray, NDArray | None, list[int]]:
    """Per traced run: its group, its profile (None unless it takes several values), its
    summary row."""
    row_of_run = {int(r): i for i, r in enumerate(summary["run"])}
    rows = [row_of_run[int(r)] for r in traces["run_ids"]]
    groups = np.array([str(summary[by][i]) for i in rows])
    parts = None
    if profile is not None and profile in summary:
        p = np.array([str(summary[profile][i]) for i in rows])
        if len(set(p.tolist())) > 1:
            parts = p
    return groups, parts, rows


def plot_force_bands(
    traces: Mapping[str, NDArray],
    summary: Mapping[str, NDArray],
    ax: Axes | None = None,
    percentiles: Sequence[float] = (5.0, 25.0, 50.0, 75.0, 95.0),
    by: str = "controller",
    profile: str | None = "radial_depths_mm",
    colors: Mapping[str, Any] | None = None,
    legend: bool = True,
) -> Axes:
    """Percentile bands of the force traces over runs, one colour per group, and the reference.

    Runs are grouped by ``by`` and, when the campaign holds several, by ``profile`` (a part
    with other depths is another response, not spread around the same one).  The legend names
    each group's colour once and the bands once (grey); see :func:`force_bands_figure` for one
    panel per profile.

    Parameters
    ----------
    traces : mapping
        ``time_s`` (n,), ``run_ids`` (runs,), ``force_N`` (runs, n)
        (:func:`acc.campaigns.sweep.read_traces`).
    summary : mapping of str to ndarray, shape (runs,)
    ax : matplotlib Axes or None
    percentiles : sequence of float
        Symmetric pairs around the median (odd count, ascending) [%].
    by : str
        Summary column that groups the runs.
    profile : str or None
        Second grouping column, used when it takes more than one value among the traced runs
        (default: the depth profile).
    colors : mapping of str to colour, optional
        Group label -> colour (default :func:`distinct_colors`, all different).
    legend : bool
        Draw the Axes' legend.

    Returns
    -------
    matplotlib Axes
    """
    ax = _axes(ax)
    p = sorted(percentiles)
    t = traces["time_s"]
    groups, parts, rows = _band_labels(traces, summary, by, profile)
    labels = groups if parts is None else np.array(
        [f"{g}, {q} mm" for g, q in zip(groups, parts, strict=True)])
    names = sorted(set(labels.tolist()))
    colors = dict(colors or distinct_colors(names))
    if "reference_force_N" in summary:
        refs = {float(summary["reference_force_N"][i]) for i in rows}
        if len(refs) == 1:
            ax.axhline(refs.pop(), color="k", ls="--", lw=0.8, label="reference")
    for g in names:
        f = traces["force_N"][labels == g]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns: no run left
            q = np.nanpercentile(f, p, axis=0)
        ax.plot(t, q[len(p) // 2], lw=1.2, color=colors[g], label=f"{g} median")
        for lo in range(len(p) // 2):
            ax.fill_between(t, q[lo], q[-1 - lo], color=colors[g], alpha=0.12 + 0.12 * lo,
                            lw=0)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("force [N]")
    ax.grid(True, alpha=0.3)
    if legend:
        handles, texts = ax.get_legend_handles_labels()
        handles += _band_handles(p)
        texts += [h.get_label() for h in _band_handles(p)]
        ax.legend(handles, texts, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                  borderaxespad=0.0)
    return ax


def _band_handles(p: Sequence[float]) -> list[Patch]:
    """Grey legend patches of the bands, widest first."""
    return [Patch(color="0.5", alpha=0.12 + 0.12 * lo, lw=0,
                  label=f"{p[lo]:g}-{p[-1 - lo]:g} % of runs")
            for lo in range(len(p) // 2)]


def force_bands_figure(
    traces: Mapping[str, NDArray],
    summary: Mapping[str, NDArray],
    by: str = "controller",
    profile: str | None = "radial_depths_mm",
    percentiles: Sequence[float] = (5.0, 25.0, 50.0, 75.0, 95.0),
) -> Figure:
    """Force percentile bands, one panel per depth profile (when the campaign has several),
    one colour per group, shared axes and one legend below the panels."""
    groups, parts, _ = _band_labels(traces, summary, by, profile)
    names = sorted(set(groups.tolist()))
    colors = distinct_colors(names)
    panels = [None] if parts is None else sorted(set(parts.tolist()))
    ncols = min(len(panels), 3)
    nrows = -(-len(panels) // ncols)
    fig, axes = plt.subplots(nrows, ncols, squeeze=False, sharex=True, sharey=True,
                             layout="constrained",
                             figsize=(7.5 if ncols == 1 else 4.2 * ncols, 2.6 * nrows + 1.0))
    for ax, part in zip(axes.ravel(), panels, strict=False):
        keep = np.ones(len(groups), bool) if part is None else parts == part
        sub = {**traces, "run_ids": traces["run_ids"][keep], "force_N": traces["force_N"][keep]}
        plot_force_bands(sub, summary, ax=ax, percentiles=percentiles, by=by, profile=None,
                         colors=colors, legend=False)
        if part is not None:
            ax.set_title(f"{column_label(profile or '')}: {part}", fontsize=9)
        if not ax.get_subplotspec().is_last_row():
            ax.set_xlabel("")
        if not ax.get_subplotspec().is_first_col():
            ax.set_ylabel("")
    for ax in axes.ravel()[len(panels):]:
        ax.set_visible(False)
    p = sorted(percentiles)
    handles: list[Any] = [Line2D([], [], color=colors[g], lw=1.5, label=f"{g} median")
                          for g in names]
    handles += _band_handles(p)
    if "reference_force_N" in summary:
        handles.append(Line2D([], [], color="k", ls="--", lw=0.8, label="reference"))
    fig.legend(handles=handles, loc="outside lower center", ncol=min(len(handles), 5),
               fontsize=8)
    return fig


__all__ = [
    "COLUMN_LABELS",
    "OUTCOMES",
    "box_stats",
    "column_label",
    "distinct_colors",
    "failure_rate_figure",
    "force_bands_figure",
    "grouping_column",
    "metrics_figure",
    "outcome_counts",
    "plot_failure_rate",
    "plot_force_bands",
    "plot_metric_distribution",
]
