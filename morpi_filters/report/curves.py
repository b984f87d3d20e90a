"""The covariance-curves page: closed form, filter sigma, Monte Carlo and field errors (README.md, result.json, PNGs)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..curves import CURVE_METHODS, MC_RUNS, NL_MAX_T, NL_RUNS, STEP_LENGTH_M, CurvesStudy
from ..deprecation import renamed_keywords, with_aliases
from ..outputs import write_json, write_text
from ..results import SectionSummary
from . import plots
from .common import banner, fmt, md_table, save_figure

__all__ = ["report_curves", "AIDED_NOTE"]

#: Where the field comparison of the MoRPI-aided filter lives (one implementation, one page).
AIDED_NOTE = ("The MoRPI-aided filter on the field recordings (forward and smoothed, against MoRPI alone and the "
              "INS alone per table cell, with its ablation and consistency) is the `aided` section: "
              "[../aided/README.md](../aided/README.md), `morpi aided`.")


@renamed_keywords(source="data_source")
def report_curves(out, study: CurvesStudy, data_source=None) -> SectionSummary:
    """Write the ``curves`` section (README.md, result.json, PNGs) into `out`.

    Parameters
    ----------
    out : path
        Staging folder to write into.
    study : curves.CurvesStudy
        What :func:`morpi_filters.curves.curves_study` computed.
    data_source : results.DataSource or None
        The recordings of the study (for the synthetic-data banner).

    Returns
    -------
    results.SectionSummary
        Name ``"curves"``, its page, one figure per case and a summary
        (no example: a curves study takes seconds).
    """
    out = Path(out)
    params, times = study.params, study.times
    field_pts, field_note = study.field_points, study.field_note
    figures, per_case, rows, field_rows = [], {}, [], []
    for cc in study.cases:
        case = cc.case
        png = f"curves_{case.name}.png"
        save_figure(plots.plot_curves(cc), out / png)
        figures.append(png)
        v = cc.at_eval_times()
        per_case[case.name] = {"title": case.title, "process_noise": case.noise is not None,
                               "gain_sigma": case.gain_sigma, **v}
        for k, p in field_pts.items():
            if p:
                d = float(np.mean([q[0] for q in p]))
                field_rows.append([case.title, k, len(p), fmt(d), fmt(np.mean([q[1] for q in p])),
                                   fmt(np.sqrt(np.mean([q[1] ** 2 for q in p]))),
                                   fmt(np.interp(d, cc.times, cc.sigma[k]))])
        rows.append([case.title, fmt(times[-1], 1)] + [fmt(v[a][k][-1]) if k in v.get(a, {}) else "-"
                                                      for k in CURVE_METHODS
                                                      for a in ("sigma_m", "rms_closed_form_m", "mc_rms_m",
                                                                "nonlinear_mc_rms_m")[: 4 if k != CURVE_METHODS[2]
                                                                                      else 3]])
    main = per_case["params"]
    result = {
        "time_s": times,
        "sigma_m": main["sigma_m"],
        "rms_closed_form_m": main["rms_closed_form_m"],
        "process_noise": bool(params.process_noise),
        "params_file": params.label,
        "step_length_m": STEP_LENGTH_M,
        "mc_runs": MC_RUNS,
        "seed": study.seed,
        "nonlinear_mc_runs": NL_RUNS,
        "cases": per_case,
        "field": {"note": field_note, "points_duration_s_error_m": field_pts},
        "field_aided": {"note": AIDED_NOTE, "section": "aided"},
    }
    write_json(out / "result.json", with_aliases(result, {"mc_seed": "seed", "times": "time_s"}))
    banner_md = banner(data_source)
    cases = [cc.case for cc in study.cases]
    head = ["case", "t [s]", "3D sigma", "3D closed RMS", "3D MC RMS", "3D strapdown MC", "2D sigma", "2D closed RMS",
            "2D MC RMS", "2D strapdown MC", "MoRPI sigma", "MoRPI-A closed RMS", "MoRPI-aided MC RMS"]
    text = (
        f"{banner_md}# Covariance curves: closed form, filter sigma, Monte Carlo\n\n"
        f"Horizontal position error [m] of 3D INS, 2D INS and MoRPI-aided 3D INS on the paper's nominal "
        f"straight-line trajectory (C = I, f^n = gravity), error parameters read as 1 sigma from "
        f"`{params.label}`. Process noise: {'on' if params.process_noise else 'off'}. The gyro z bias is left "
        f"out, as in the paper (common heading error). MoRPI steps of {STEP_LENGTH_M} m every "
        f"{STEP_LENGTH_M / params.morpi_speed_mps:g} s, gain error 1 sigma {abs(params.dG[0]):g} as a constant "
        f"augmented state. Monte Carlo: {MC_RUNS} seeded runs of the linear model (seed {study.seed}); for "
        f"MoRPI-aided, the RMS of the filter's own estimation error. For the two IMU cases a second Monte "
        f"Carlo ({NL_RUNS} runs, for evaluation times up to {NL_MAX_T:g} s) synthesizes the IMU at rest (`simulate.imu`, datasheet biases on all axes) and "
        f"runs the nonlinear 3D/2D strapdown; where it departs from the filter sigma the linear error model "
        f"no longer holds (large tilt from the gyro bias).\n\n"
        f"At the last requested time:\n\n" + md_table(head, rows) + "\n"
        + "".join(f"![{c.title}]({png})\n\n" for c, png in zip(cases, figures))
        + f"{'Synthetic' if data_source is not None and data_source.synthetic else 'Field'} recordings: {field_note}.\n\n"
        + (md_table(["case", "method", "runs", "mean duration [s]", "mean end error [m]", "RMS end error [m]",
                     "filter 1 sigma at the mean duration [m]"], field_rows) if field_rows else "")
        + "\n## MoRPI-aided INS on the field recordings\n\n" + AIDED_NOTE + "\n"
    )
    write_text(out / "README.md", text)
    summary = (f"Filter sigma vs closed form vs Monte Carlo for 3D/2D INS and MoRPI-aided INS. "
               f"At {fmt(times[-1], 0)} s (parameter file): 3D {fmt(main['sigma_m']['INS-3D'][-1])} m, "
               f"2D {fmt(main['sigma_m']['INS-2D'][-1])} m, MoRPI-aided {fmt(main['sigma_m']['MoRPI-aided INS'][-1])} "
               "m (1 sigma).")
    return SectionSummary(name="curves", title="Covariance curves", page="README.md", figures=tuple(figures),
                          summary=summary, synthetic=bool(data_source is not None and data_source.synthetic))
