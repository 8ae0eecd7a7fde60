"""The plan's report page: a Markdown page with the table and two figures, the JSON and the manifest.

Written by :func:`write_plan` into one folder:

* ``plan.md``: the table, the figures, the method and the notes;
* ``plan.json``: every number (:meth:`~dronewind.plan.planner.CampaignPlan.to_json`);
* ``campaign.yaml``: the manifest skeleton (virtual campaign, ``docs/manifest.md``);
* ``uncertainty_vs_hover.png``: the predicted relative uncertainty of each targeted quantity
  against the hover duration at the lowest and highest planned wind speed, with the targets
  and the planned duration;
* ``power_vs_flights.png`` (when the power was simulated): the detection power of each error
  against the number of flights with its 95 % Wilson interval, the target power and the
  planned number (the counts up to the first at which every error reaches the target power:
  the planned one, :func:`~dronewind.plan.planner.plan_campaign`).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from dronewind.plan.planner import CampaignPlan

__all__ = ["write_plan", "uncertainty_figure", "power_figure"]

_LABELS = {"sigma_u": r"$\sigma_u$", "sigma_w": r"$\sigma_w$", "u_star": r"$u_*$", "w_theta": r"$\overline{w'\theta'}$"}


def uncertainty_figure(plan: CampaignPlan, path: str | Path) -> Path:
    """Relative uncertainty against hover duration (module docstring); returns the PNG path."""
    from dronewind.figures.style import new_figure

    fig = new_figure(6.4, 4.0)
    ax = fig.add_subplot(1, 1, 1)
    tau = np.linspace(60.0, max(2.0 * plan.duration_s, plan.spec.max_hover_s), 200)
    quantities = list(plan.spec.targets) or ["sigma_w", "u_star", "w_theta"]
    colours = dict(zip(("sigma_u", "sigma_w", "u_star", "w_theta"), ("C0", "C1", "C2", "C3"), strict=True))
    speeds = sorted(plan.points)
    for u in speeds:
        point = plan.points[u]
        style = "-" if u == speeds[0] else "--"
        for q in quantities:
            eps = [point.relative(t)[q] for t in tau]
            ax.plot(tau / 60.0, eps, style, color=colours[q], label=f"{_LABELS[q]} at {u:g} m/s")
    for q in quantities:
        if q in plan.spec.targets:
            ax.axhline(plan.spec.targets[q], color=colours[q], lw=0.8, ls=":")
    ax.axvline(plan.duration_s / 60.0, color="k", lw=1.0, label=f"planned hover {plan.duration_s / 60:.1f} min")
    ax.axvline(plan.spec.max_hover_s / 60.0, color="0.5", lw=0.8, ls="-.", label="longest hover")
    ax.set_xlabel("hover duration [min]")
    ax.set_ylabel("relative random uncertainty [1]")
    ax.set_yscale("log")
    ax.set_title(f"{plan.spec.name}: predicted uncertainty (dotted: targets)")
    ax.legend(fontsize=7, ncol=2)
    out = Path(path)
    fig.savefig(out, dpi=120)
    return out


def power_figure(plan: CampaignPlan, path: str | Path) -> Path:
    """Detection power against the number of flights (module docstring); returns the PNG path."""
    from dronewind.figures.style import new_figure

    fig = new_figure(6.4, 4.0)
    ax = fig.add_subplot(1, 1, 1)
    for i, (label, curve) in enumerate(plan.power_curve.items()):
        k = np.array([r.n_flights for r in curve])
        p = np.array([r.power for r in curve])
        ci = np.array([r.interval for r in curve])
        # the Wilson bounds of 0 and all draws are 0 and 1 to rounding
        bars = ax.errorbar(k + 0.06 * (i - 1), p, yerr=np.clip([p - ci[:, 0], ci[:, 1] - p], 0.0, None), marker="o",
                           capsize=3, label=label)
        final = plan.power.get(label)
        if final is not None:  # the power at the plan's count, from all its draws
            lo, hi = final.interval
            ax.errorbar([final.n_flights + 0.06 * (i - 1) + 0.2], [final.power],
                        yerr=[[max(final.power - lo, 0.0)], [max(hi - final.power, 0.0)]], marker="*", ms=9, capsize=3,
                        color=bars.lines[0].get_color(), ls="none")
    ax.axhline(plan.spec.power, color="k", lw=0.8, ls=":", label=f"target power {plan.spec.power:g}")
    ax.axvline(plan.n_flights, color="0.4", lw=1.0, label=f"planned: {plan.n_flights} flights")
    # the whole range the plan may fly: counts above the first that meets the target are not simulated
    ax.set_xlim(0.5, plan.spec.max_flights + 0.5)
    ax.set_xlabel("number of flights")
    ax.set_ylabel("detection power [1]")
    ax.set_ylim(-0.02, 1.02)
    draws = next(iter(plan.power_curve.values()))[0].draws if plan.power_curve else 0
    finals = next(iter(plan.power.values())).draws if plan.power else 0
    ax.set_title(f"{plan.spec.name}: detection power\n{draws} draws per point, {finals} per star (the plan's count), "
                 "95 % Wilson intervals", fontsize=9)
    ax.legend(fontsize=7)
    out = Path(path)
    fig.savefig(out, dpi=120)
    return out


def _markdown(plan: CampaignPlan, figures: list[str]) -> str:
    s = plan.spec
    lo, hi = (f"{u:g}" for u in plan.speed_range_ms)
    rows = ["| quantity | target | predicted at lowest speed | predicted at highest speed | met |",
            "|---|---|---|---|---|"]
    for q, v in plan.uncertainty[lo].items():
        target = s.targets.get(q)
        met = "" if target is None else ("yes" if plan.targets_met[q] else "**no**")
        rows.append(f"| {q} | {'' if target is None else f'{target:.3f}'} | {v:.3f} | "
                    f"{plan.uncertainty[hi][q]:.3f} | {met} |")
    power_rows = []
    if plan.power:
        power_rows = ["| error to detect | power | 95 % interval | draws | target met |", "|---|---|---|---|---|"]
        for label, r in plan.power.items():
            a, b = r.interval
            power_rows.append(f"| {label} | {r.power:.2f} | {a:.2f}-{b:.2f} | {r.detected}/{r.draws} | "
                              f"{'yes' if r.power >= s.power else '**no**'} |")
        if plan.false_alarm is not None:
            a, b = plan.false_alarm.interval
            power_rows.append(f"| false alarm (no error) | {1 - plan.false_alarm.power:.2f} | "
                              f"{1 - b:.2f}-{1 - a:.2f} | "
                              f"{plan.false_alarm.draws - plan.false_alarm.detected}/{plan.false_alarm.draws} | |")
    lines = [
        f"# Campaign plan {s.name}", "",
        f"Platform {s.platform}; hover at {s.hover_height_m:g} m beside the mast sonic at "
        f"{s.reference_height_m:g} m; wind from {s.wind_from_deg:g} degree, Obukhov length "
        f"{s.obukhov_length_m:g} m, roughness length {s.roughness_length_m:g} m.", "",
        "| answer | value |", "|---|---|",
        f"| hover duration | {plan.duration_s / 60:.1f} min ({plan.duration_s:.0f} s) |",
        f"| largest drone-mast separation | {plan.separation_limit_m:.0f} m across the wind, "
        f"{plan.along_wind_limit_m:.0f} m along it |",
        f"| planned distance | {plan.distance_m:.0f} m across the wind |",
        f"| number of flights | {plan.n_flights} |",
        f"| wind speeds of the flights | {', '.join(f'{u:g}' for u in plan.speeds_ms)} m/s |",
        f"| wind range to span | {plan.speed_range_ms[0]:g}-{plan.speed_range_ms[1]:g} m/s |", "",
        "## Predicted relative random uncertainty per flight", "", *rows, "",
    ]
    if power_rows:
        lines += ["## Detection power", "", *power_rows, "", plan.power_note, ""]
    elif plan.power_note:
        lines += [plan.power_note, ""]
    lines += [f"![{f}]({f})" for f in figures] + [""]
    if plan.notes:
        lines += ["## Notes", ""] + [f"* {n}" for n in plan.notes] + [""]
    lines += [
        "## Method", "",
        "Uncertainties: relative random error of the hover's statistics (Ghirardelli et al. 2025, Eqs 10-13, "
        "in the ergodic form of Lumley and Panofsky 1964) with the integral time scales and normalised "
        "variances of the product series of the forward simulation's turbulence at the hover point "
        "(dronewind.plan.uncertainty). Separation: the largest distance at which the drone's and the mast's "
        "horizontal wind series stay correlated (at least "
        f"{s.min_correlation:g}) under the simulator's coherence model (dronewind.plan.separation). "
        "Power: dronewind.plan.power. The campaign manifest `campaign.yaml` runs as a virtual campaign.", ""]
    return "\n".join(lines)


def write_plan(plan: CampaignPlan, out_dir: str | Path) -> list[Path]:
    """Write the plan's report page, JSON, manifest and figures into ``out_dir``.

    Parameters
    ----------
    plan : CampaignPlan
        From :func:`dronewind.plan.planner.plan_campaign`.
    out_dir : str or Path
        Folder (created).

    Returns
    -------
    list of Path
        The files written.
    """
    import yaml

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = [uncertainty_figure(plan, out / "uncertainty_vs_hover.png")]
    if plan.power_curve:
        written.append(power_figure(plan, out / "power_vs_flights.png"))
    (out / "plan.md").write_text(_markdown(plan, [p.name for p in written]), encoding="utf-8")
    (out / "plan.json").write_text(json.dumps(plan.to_json(), indent=1, default=float) + "\n", encoding="utf-8")
    header = (f"# Campaign planned by `dronewind plan` for {plan.spec.name}: {plan.n_flights} flights of "
              f"{plan.duration_s / 60:.1f} min at {plan.spec.hover_height_m:g} m, {plan.distance_m:.0f} m from the "
              "mast.\n"
              "# A virtual campaign (simulation: section); for the measured one replace the files and windows by the "
              "flown records and drop simulation:.\n")
    (out / "campaign.yaml").write_text(header + yaml.safe_dump(plan.manifest, sort_keys=False), encoding="utf-8")
    return [*written, out / "plan.md", out / "plan.json", out / "campaign.yaml"]
