"""The Monte Carlo pages: the gain-error study and the closed-form vs strapdown drift (README.md, result.json, PNGs)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..deprecation import renamed_keywords, with_aliases
from ..montecarlo import DIGEST_BITS, Z99, DriftPage, GainErrorPage, study_config_json, final_statistics, summarize
from ..outputs import write_json, write_text
from ..results import SectionSummary
from ..units import DEG_S, MG
from . import plots
from .common import collector_paused, banner, fmt, md_table, save_figure

__all__ = ["report_montecarlo", "report_drift"]


@renamed_keywords(source="data_source")
def report_montecarlo(out, study: GainErrorPage, data_source=None) -> SectionSummary:
    """Write the gain-error Monte Carlo section (README.md, result.json, PNGs) into folder `out`.

    Parameters
    ----------
    out : path
        Staging folder of the section.
    study : montecarlo.GainErrorPage
        What :func:`morpi_filters.montecarlo.gain_error_page` computed.
    data_source : results.DataSource or None
        The dataset of the trained gains (for the synthetic-data banner).

    Returns
    -------
    results.SectionSummary
        The section's name, page, figures and summary (no example: the
        study and its figures take seconds).
    """
    out = Path(out)
    runs, seed = study.runs, study.seed
    r, rr, tr, checks = study.calibrated, study.raw, study.training, study.checks
    cal, raw = r.config, rr.config
    spread, mismatch, spread_note, assumed = study.spread, study.mismatch, study.spread_note, study.assumed

    # the figures come with their margins fitted to their labels (no layout pass): each is saved in one draw
    figs = []
    with collector_paused():
        figs.append(save_figure(plots.montecarlo_final_errors(
            r.columns, r.final, title=f"{cal.spec.name}, {cal.duration_s:g} s, {runs} runs, GAC-calibrated biases"),
            out / "final_errors.png").name)
        figs.append(save_figure(plots.montecarlo_error_curves(
            r.time, r.bands, ["INS-3D", "INS-2D", "MoRPI-A (dG 5 %)", "MoRPI-G (dG 5 %)"],
            title="horizontal error over time (median, 5-95 % band)"), out / "error_curves.png").name)
        s_i = 2
        figs.append(save_figure(plots.montecarlo_gain_vs_error(
            r.dG[:, s_i], r.distance_error[:, s_i, 0], analytic_slope=r.distance,
            title="MoRPI-A distance error against the gain error (training-spread scenario)"),
            out / "gain_vs_distance_error.png").name)
        figs.append(save_figure(plots.montecarlo_training_runs(
            tr.k, tr.rms_distance, tr.rms_expected, ["MoRPI-A", "MoRPI-G"],
            title=f"gain from k training runs: spread {100 * spread:g} %, mismatch {100 * mismatch:g} %"),
            out / "training_runs.png").name)

    result = {
        "runs": runs, "seed": seed, "digest": r.digest, **final_statistics(r),
        "unit": "m, final horizontal position error",
        "config": study_config_json(cal), "columns": list(r.columns), "distance_m": r.distance,
        "gain_ref": {"MoRPI-A": r.gain_ref[0], "MoRPI-G": r.gain_ref[1],
                     "training_cv": {"MoRPI-A": r.gain_ref_cv[0], "MoRPI-G": r.gain_ref_cv[1]}},
        "scenarios": [{**c, "final": {m: summarize(r.final_error(m, c["label"])) for m in ("MoRPI-A", "MoRPI-G")}}
                      for c in checks],
        "confidence": {"z": Z99, "bound": "mean +/- z * std / sqrt(runs)"},
        "raw_biases": {"digest": rr.digest, "config": study_config_json(raw), **final_statistics(rr)},
        "training_runs": with_aliases({
            "k": tr.k, "mismatch": tr.mismatch, "spread": tr.spread, "assumed": assumed,
            "spread_basis": spread_note if not assumed else f"assumed ({spread_note})",
            "rms_distance": {"MoRPI-A": tr.rms_distance[:, 0], "MoRPI-G": tr.rms_distance[:, 1]},
            "rms_expected": tr.rms_expected, "digests": list(tr.digests)}, {"source": "spread_basis"}),
        "backends": r.backends,
    }
    write_json(out / "result.json", result)

    synthetic = study.synthetic
    lines = [banner(data_source) + "# Monte Carlo gain-error study\n"]
    lines.append(
        f"{runs} seeded runs (seed {seed}) of {cal.spec.name} errors over {cal.duration_s:g} s at "
        f"{cal.rate_hz:g} Hz. The robot drives a sine path of {cal.length_m:g} m (simulate.sine: period "
        f"{cal.p2p_m:g} m, amplitude {cal.amplitude_m:g} m, tapered over the first and last period; "
        f"1 s ramps from and to rest, cruise at {cal.speed_mps:.3g} m/s). "
        + ("INS-3D and INS-2D navigate that same path; " if cal.ins_path == "sine" else
           f"INS-3D and INS-2D drive a straight line of the same length and speed; ")
        + f"MoRPI-A and MoRPI-G take {r.steps} Weinberg steps between the "
        f"f_y maxima (D = {r.distance:.2f} m). Every run draws turn-on biases, white noise at "
        f"{cal.rate_hz:g} Hz from the datasheet densities, and one gain number; the MoRPI reference gains "
        f"are the mean of {cal.training_runs} noisy training runs (per-run gain spread from sensor noise: "
        f"{100 * r.gain_ref_cv[0]:.3f} % for MoRPI-A, {100 * r.gain_ref_cv[1]:.4f} % for MoRPI-G).\n")
    ca, cg = cal.bias_sigmas()
    lines.append(
        f"Biases: *raw* uses the datasheet turn-on biases ({cal.spec.accel_bias:.3g} m/s^2, "
        f"{cal.spec.gyro_bias:.3g} rad/s, 1 sigma per axis); *GAC-calibrated* assumes the paper's zero-order "
        f"gyro and accelerometer calibration on {cal.cal_window_s:g} s of rest, which leaves the mean of the white "
        f"noise over that window ({ca:.3g} m/s^2, {cg:.3g} rad/s). The MoRPI position starts at the first f_y "
        "peak (known there) and moves at each later peak; its heading is the true heading plus the integrated "
        "gyro-z error.\n")
    lines.append(f"Digest (sha256 of the per-run final errors rounded to {DIGEST_BITS} significant bits, about six "
                 f"digits, so that another machine's last-digit differences leave it unchanged: "
                 f"`montecarlo.digest`): `{r.digest}`; with raw biases: `{rr.digest}`.\n")
    lines.append("## Final horizontal position error [m]\n")
    rows = []
    for label, res in (("GAC-calibrated (3 s rest)", r), ("raw datasheet biases", rr)):
        for c in res.columns:
            st = summarize(res.column(c))
            rows.append([label, c, fmt(st["mean"], 3), fmt(st["std"], 3), fmt(st["median"], 3), fmt(st["p95"], 3)])
    lines.append(md_table(["biases", "method", "mean", "std", "median", "p95"], rows))
    lines.append(
        "\nWith raw datasheet biases the MoRPI position error is dominated by the heading drift of the "
        "gyro-z bias, the same for every method; after calibration the gain error dominates.\n")
    lines.append("## MoRPI distance error against the analytical ds = dG D\n")
    lines.append(f"The analytical distance error of a run with gain error dG is ds = sum_k dG G df_k = dG D "
                 f"(paper, Section III-A), with D = {r.distance:.3f} m the sum of the true peak-to-peak chords. "
                 "For each scenario the analytical value is averaged over the same dG draws as the Monte Carlo; "
                 f"the check is |mean(x - dG D)| <= z std(x - dG D) / sqrt(N), z = {Z99:.3f} (99 %). "
                 "The residual spread is the sensor noise's effect on the Weinberg terms.\n")
    rows = []
    for c in checks:
        for name in ("MoRPI-A", "MoRPI-G"):
            v = c[name]
            rows.append([c["label"], name, fmt(c["analytic_mean"], 4), fmt(v["mc_mean"], 4),
                         fmt(v["residual_mean"], 5), fmt(v["bound"], 5), "yes" if v["within"] else "NO",
                         fmt(c["analytic_std_gain_only"], 4), fmt(v["mc_std"], 4)])
    lines.append(md_table(["scenario", "method", "analytical ds [m]", "MC mean [m]", "difference [m]",
                           "+/- bound [m]", "within", "analytical std (gain) [m]", "MC std [m]"], rows))
    lines.append("\n## Gain from k training runs\n")
    src = (f"Per-run gain spread {100 * spread:g} % and motion mismatch {100 * mismatch:g} % "
           + (f"from the {spread_note}." if not assumed else
              f"are ASSUMED values: the field gain spread could not be computed ({spread_note})."))
    lines.append(src + " The gain is the mean of k per-run gains, so dG ~ N(mismatch, spread^2 / k) and "
                 "the RMS distance error approaches D |mismatch| like 1/sqrt(k).\n")
    rows = [[int(k), fmt(a, 4), fmt(g, 4), fmt(e, 4)] for k, (a, g), e in zip(tr.k, tr.rms_distance, tr.rms_expected)]
    lines.append(md_table(["k", "MoRPI-A RMS [m]", "MoRPI-G RMS [m]", "D sqrt(m^2 + s^2/k) [m]"], rows))
    lines.append("\n## Figures\n")
    lines.extend(f"![{f}]({f})\n" for f in figs)
    write_text(out / "README.md", "\n".join(lines))

    st = final_statistics(r)
    summary = (f"{runs} runs, {cal.spec.name}, {cal.duration_s:g} s (GAC-calibrated): mean final error INS-3D "
               f"{fmt(st['INS-3D']['mean'])} m, INS-2D {fmt(st['INS-2D']['mean'])} m, MoRPI-A (dG 5 %) "
               f"{fmt(st['MoRPI-A']['mean'])} m, MoRPI-G {fmt(st['MoRPI-G']['mean'])} m. "
               f"MoRPI distance error vs ds = dG D: "
               + ", ".join(f"{c['label']} {'within' if c['MoRPI-A']['within'] else 'OUTSIDE'}" for c in checks)
               + " the 99 % bound.")
    return SectionSummary(name="montecarlo", title="Monte Carlo gain-error study", page="README.md",
                          figures=tuple(figs), summary=summary, synthetic=synthetic)


def report_drift(out, study: DriftPage) -> SectionSummary:
    """Write the closed-form vs strapdown drift section (README.md, result.json, PNGs) into folder `out`.

    Parameters
    ----------
    out : path
        Staging folder of the section.
    study : montecarlo.DriftPage
        What :func:`morpi_filters.montecarlo.drift_page` computed.

    Returns
    -------
    results.SectionSummary
        The section's name, page, figures and summary (no example: the
        study and its figures take seconds).
    """
    out = Path(out)
    spec, d, growth, onset = study.spec, study.drift, study.growth, study.onset
    bdeg = d.gyro_bias / DEG_S
    figs = []
    s6 = spec.gyro_bias / DEG_S
    for kind, rel in (("INS-3D", d.rel_3d), ("INS-2D", d.rel_2d)):
        figs.append(save_figure(plots.drift_disagreement_map(
            bdeg, d.time, rel, marks=[(s6, 14.0, "S6 datasheet, 14 s")],
            title=f"{kind.upper()} INS at rest: strapdown vs small-angle closed form "
                  f"(median of {d.draws} draws)"), out / f"drift_map_{kind[-2:].lower()}.png").name)
    result = {
        "gyro_bias_deg_s": bdeg, "time_s": d.time, "rel_3d": d.rel_3d, "rel_2d": d.rel_2d,
        "p90_3d": d.p90_3d, "p90_2d": d.p90_2d,
        "final_3d_m": {"strapdown": d.final_3d[:, 0], "closed_form": d.final_3d[:, 1]},
        "final_2d_m": {"strapdown": d.final_2d[:, 0], "closed_form": d.final_2d[:, 1]},
        "onset_s": onset, "growth": growth, "accel_bias_sigma_mps2": d.accel_bias,
        "draws": d.draws, "seed": d.seed, "backends": d.backends,
        "metric": "median over draws of |dp_strapdown - dp_closed_form| / |dp_strapdown|, horizontal",
    }
    write_json(out / "result.json", result)
    lines = ["# Closed-form vs strapdown drift\n"]
    lines.append(
        f"An INS at rest for 15 s at 100 Hz with constant biases: accelerometer {spec.accel_bias / MG:g} mg "
        f"1 sigma per axis ({spec.name} datasheet), gyro bias levels from {bdeg[0]:g} to {bdeg[-1]:g} deg/s "
        f"1 sigma per axis; {d.draws} draws shared by every level. Each draw goes through the nonlinear "
        "strapdown (3D and planar 2D) and through the small-angle closed form of the 15-state model "
        "(C = I, f^n = gravity, gyro-z terms kept). The map shows the median relative disagreement of the "
        "horizontal position error.\n")
    lines.append(f"The {spec.name} datasheet gyro bias, {s6:g} deg/s, turns the attitude by {s6 * 14:g} degrees "
                 "in 14 s, far outside the small-angle range.\n")
    rows = []
    pick = np.unique([int(np.argmin(np.abs(bdeg - b))) for b in (0.01, 0.1, 0.3, 1.0, 3.0, s6, 10.0)])
    for i in pick:
        rows.append([fmt(bdeg[i], 3), fmt(100 * d.rel_3d[i, -1], 3), fmt(onset["INS-3D_1pct"][i], 1),
                     fmt(onset["INS-3D_10pct"][i], 1), fmt(100 * d.rel_2d[i, -1], 3), fmt(onset["INS-2D_1pct"][i], 1),
                     fmt(onset["INS-2D_10pct"][i], 1)])
    lines.append(md_table(["gyro bias [deg/s]", "3D at 15 s [%]", "3D > 1 % from [s]", "3D > 10 % from [s]",
                           "2D at 15 s [%]", "2D > 1 % from [s]", "2D > 10 % from [s]"], rows))
    lines.append(
        f"\nHow fast they part: near 1 % the 3D disagreement grows like t^{fmt(growth['INS-3D']['slope_in_time'], 2)} "
        f"(at {fmt(growth['INS-3D']['slope_in_time_bias_deg_s'], 2)} deg/s) and like "
        f"b^{fmt(growth['INS-3D']['slope_in_bias_at_end'], 2)} in the bias at 15 s; for 2D t^"
        f"{fmt(growth['INS-2D']['slope_in_time'], 2)} and b^{fmt(growth['INS-2D']['slope_in_bias_at_end'], 2)}. "
        "A single-axis rotation by x = b t makes the cubic closed form overshoot the exact "
        "g (t / b - sin(b t) / b^2) by x^3 / (6 (x - sin x)) - 1, about x^2 / 20, so exponents near 2 are "
        "the signature of the small-angle linearization (in 3D the accelerometer-bias terms, exact in "
        "both, dilute it at short times). A '-' marks a bias that stays below the level for the whole 15 s.\n")
    lines.append("## Figures\n")
    lines.extend(f"![{f}]({f})\n" for f in figs)
    write_text(out / "README.md", "\n".join(lines))
    i6 = int(np.argmin(np.abs(bdeg - s6)))
    summary = (f"Closed form vs nonlinear strapdown at rest: at 15 s they differ by "
               f"{fmt(100 * d.rel_3d[0, -1], 3)} % (3D) at {fmt(bdeg[0], 2)} deg/s and by "
               f"{fmt(100 * d.rel_3d[i6, -1], 0)} % (3D) / {fmt(100 * d.rel_2d[i6, -1], 0)} % (2D) at "
               f"{fmt(bdeg[i6], 1)} deg/s (S6 datasheet).")
    return SectionSummary(name="drift", title="Closed-form vs strapdown drift", page="README.md",
                          figures=tuple(figs), summary=summary, synthetic=False)
