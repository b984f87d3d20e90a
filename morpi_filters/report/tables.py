"""The tables page: the paper's tables on the recordings, ours beside the paper's (README.md, result.json, PNGs)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..evaluate import (
    INS_METHODS, DEVIATION_PP, TABLES, Cell, TablesStudy, rule_json,
)
from ..deprecation import renamed_keywords, with_aliases
from ..fetch import dataset_identity
from ..field import MORPI_METHODS
from ..outputs import write_json, write_text
from ..results import SectionSummary
from . import plots
from .common import collector_paused, banner, fmt, md_table, save_figure

__all__ = ["report_tables", "result_json", "TRAIN_SE_BAND"]


@renamed_keywords(source="data_source")
def report_tables(out, study: TablesStudy, data_source) -> SectionSummary:
    """Write the tables section: README.md, result.json and figures in `out`.

    Parameters
    ----------
    out : path
        Section folder (a staging folder from the CLI).
    study : evaluate.TablesStudy
        What :func:`morpi_filters.evaluate.tables_study` computed on ``data_source.root``.
    data_source : results.DataSource
        The dataset root; when synthetic, every page starts with its banner.

    Returns
    -------
    results.SectionSummary
        Name ``"tables"``, its page, figures and summary (no example: the
        study needs a dataset).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    res, left_out = study.result, list(study.left_out)
    payload = result_json(study, data_source)
    payload["partial"] = study.partial
    payload["left_out"] = left_out
    payload["no_rest"] = list(study.no_rest)
    figures = _figures(study, out)
    write_json(out / "result.json", payload)
    page = _page(study, payload, data_source, figures)
    write_text(out / "README.md", page)
    n_ok = sum(1 for c in res.cells if c.runs)
    gc6 = [c for c in res.cells if c.spec.table == "short_route" and c.spec.calibration == "GC" and c.runs]
    within = sum(1 for c in gc6 if abs(c.deviation_pp) <= DEVIATION_PP)
    summary = (f"{n_ok} of {len(res.cells)} table cells computed on "
               f"{'synthetic data' if data_source.synthetic else 'the field recordings'}; "
               f"{within} of {len(gc6)} short-route GC MoRPI cells within {DEVIATION_PP} pp of the paper.")
    if res.missing:
        summary += f" Missing folders: {', '.join(res.missing)}."
    if left_out:
        summary += f" Partial evaluation: {len(left_out)} recording problem(s) left out (see the page)."
    if study.no_rest:
        summary += f" {len(study.no_rest)} recording(s) without an initial rest: RD only (see the page)."
    return SectionSummary(name="tables", title="The paper's tables on the recordings", page="README.md",
                          figures=tuple(figures), summary=summary, synthetic=bool(data_source.synthetic))


def _figures(study: TablesStudy, out: Path) -> list[str]:
    """Draw the page's figures from the study and save them in `out`; their file names."""
    figs = []
    # the figures come with their margins fitted to their labels (no layout pass): each is saved in one draw
    with collector_paused():
        for v in study.recordings:
            save_figure(plots.plot_recording(v.time, v.f, v.omega, title=v.title, rest=v.rest, motion=v.motion,
                                             peaks=v.peaks), out / v.name)
            figs.append(v.name)
        for v in study.tracks:
            save_figure(plots.plot_tracks(v.tracks, v.truth, title=v.title, equal=False), out / v.name)
            figs.append(v.name)
        if study.path_panels:
            save_figure(plots.plot_path_sets(list(study.path_panels)), out / "morpi_paths.png")
            figs.append("morpi_paths.png")
    return figs


def _fold_threshold_note(nest) -> str:
    """How the folds' thresholds differ from the full train set's, in words."""
    folds = nest.get("folds") or []
    if not folds:
        return "no folds"
    swing = sorted({f["min_swing_deg"] for f in folds})
    turn = sorted({f["turn_deg"] for f in folds})
    moved = sum(not f["same_rest_windows"] for f in folds)
    return (f"least swing {' / '.join(f'{v:g}' for v in swing)} deg and least turn "
            f"{' / '.join(f'{v:g}' for v in turn)} deg over the folds; the fold's floor moves a rest window in "
            f"{moved} of {len(folds)} folds")


def _heading_section(payload) -> list:
    """MoRPI cells under the two heading sources and origins (:func:`morpi_filters.evaluate.heading_readings`)."""
    hr = payload.get("heading_readings") or {}
    if not hr.get("cells"):
        return []
    used = hr["used"]["heading_source"]
    L = ["## Heading: z gyro or 3D attitude, from the motion onset or the first sample", "",
         "The paper's heading equation reads the heading from the attitude matrix of the 3D mechanization; the "
         "planar reading integrates the z gyro alone. Both are candidates of the step-rule search, so the train "
         "runs choose between them like every other reading: "
         + ", ".join(f"{m} reads the `{v}`" for m, v in used.items()) + ". The attitude's mechanization starts "
         "with the roll and pitch of the rest specific force. Both are integrated from the start of the motion "
         "window; integrated from the first sample instead (the project's earlier reading), the raw gyro's bias "
         "turns the heading during the initial rest, before the robot moves, which mostly shows in the RD cells. "
         "Other fields of the step rules as chosen; gains retrained under each reading on the train runs.", ""]
    rows = []
    for c in hr["cells"]:
        p2p = f"{c['p2p_m']:g} m" if c["p2p_m"] is not None else ""
        rows.append([c["table"], c["phone"], p2p, c["method"], c["calibration"], fmt(c["paper_percent"]),
                     c["chosen_source"], fmt(c["from_motion_percent"]), fmt(c["gyro_percent"]),
                     fmt(c["attitude_percent"]), fmt(c["from_start_percent"])])
    L += [md_table(["table", "phone", "p2p", "method", "cal", "paper %", "source (train-chosen)", "used %",
                    "z gyro from motion onset %", "3D attitude from motion onset %",
                    "chosen source from first sample (old) %"], rows)]
    lines = []
    for m, t in hr.get("train", {}).items():
        if t["difference_pp"] is None:
            continue
        lines.append(f"- {m}: train leave-one-out error {fmt(t['gyro_loo_percent'])} % with the z gyro, "
                     f"{fmt(t['attitude_loo_percent'])} % with the 3D attitude (attitude minus gyro "
                     f"{t['difference_pp']:+.3f} ± {t['difference_se_pp']:.3f} pp over {t['n_train_runs']} runs); "
                     f"chosen: `{t['chosen_source']}`.")
    if lines:
        L += ["What the train runs see of the two sources (the chosen rule, GC). The search scores the sources "
              "with the start tunables and tunes the winner, so a source can win by a margin within its noise:",
              ""] + lines + [""]
        weak = [m for m, t in hr["train"].items()
                if t["difference_pp"] is not None and abs(t["difference_pp"]) <= 2 * t["difference_se_pp"]]
        if weak:
            L += [f"For {', '.join(weak)} the two sources differ by less than two standard errors of their paired "
                  "difference: the train runs barely tell them apart, and the choice is a weak one. The test cells "
                  "above are shown, never used for the choice.", ""]
    return L


def _turn_section(payload) -> list:
    """Long-route and L-route MoRPI cells under every heading reading (:func:`morpi_filters.evaluate.turn_reading`)."""
    tr = payload.get("turn_reading") or {}
    if not tr.get("cells"):
        return []
    th = tr["threshold"]
    heads = tr["headings"]
    L = ["## A heading that follows turns", "",
         "The `change` reading (each step's direction is its own heading change) never accumulates the gyro's "
         "drift, but it cannot follow a turn: on the L route it points the second leg along the first. The "
         "`turns` reading adds to each step's own change the turns so far: a full period (two half-period steps "
         "between extrema, one step between maxima) turns when its heading change exceeds "
         f"{fmt(th['turn_deg'], 0)} deg; turning periods that overlap merge into one stretch, widened by a period "
         "on each side (a turn eases in and out below the threshold), whose turn is the mean heading over the "
         "period after it minus the mean over the period before it (the zigzag cancels "
         "from a period's mean), so a turn spread over several periods counts in full. The threshold comes "
         "from the train runs only, which are all straight: "
         + (f"{th['margin']:g} times the largest full-period heading change they show "
            f"({fmt(th['largest_train_period_change_deg'], 1)} deg over {th['n_train_values']} runs and methods, "
            "GC, half-period steps at the search's start rule), rounded down (`field.train_thresholds`). "
            if th["largest_train_period_change_deg"] is not None else "none here, so the library's default. ")
         + "The search scores `turns` with the other readings.", ""]
    rows = []
    for c in tr["cells"]:
        rows.append([c["table"], c["phone"], c["method"], c["calibration"], fmt(c["paper_percent"]),
                     f"{fmt(c['chosen_percent'])} ({c['chosen_heading']})"]
                    + [fmt(c[f"{h}_percent"]) for h in heads])
    L += ["Mean end-point error [%] of the test runs under each heading reading, the rest of each method's chosen "
          "rule kept, gains retrained under each:", "",
          md_table(["table", "phone", "method", "cal", "paper %", "chosen %"] + [f"{h} %" for h in heads], rows)]
    L += ["Train leave-one-out error [%] of each reading (short-route train runs, GC; what the search sees): "
          + "; ".join(f"{m}: " + ", ".join(f"`{h}` {fmt(v)}" for h, v in t.items()) for m, t in tr["train"].items())
          + ".", ""]
    lines = []
    for m, runs in tr["l_route_turns_deg"].items():
        if runs:
            v = np.array([r["turn_deg"] for r in runs])
            lines.append(f"- {m}: {fmt(float(v.mean()), 1)} deg on average (from {fmt(float(v.min()), 1)} to "
                         f"{fmt(float(v.max()), 1)}; {sum(r['stretches'] == 1 for r in runs)} of {len(runs)} runs "
                         "with exactly one turning stretch)")
    if lines:
        L += [f"The turn the `turns` reading finds on each L-route test run (GC; the route turns "
              f"{fmt(tr['route_turn_deg'], 0)} deg):", ""] + lines + [""]
    return L


def _claims_section(claims) -> list:
    """The paper's numeric claims beside ours (:func:`morpi_filters.evaluate.paper_claims`)."""
    if not claims:
        return []

    def show(v):
        if isinstance(v, (list, tuple)):
            return " / ".join(show(x) for x in v)
        return "-" if v is None else (f"{v:g}" if isinstance(v, (int, float)) else str(v))

    held = sum(c["holds"] is True for c in claims)
    rows = [[c["claim"], show(c["paper"]), show(c["ours"]),
             {True: "yes", False: "**no**", None: "-"}[c["holds"]], c["evidence"]] for c in claims]
    return ["## The paper's claims", "",
            f"Each numeric claim of the paper's results and conclusions, ours beside it: {held} of "
            f"{len(claims)} hold on these recordings.", "",
            md_table(["claim", "paper", "ours", "holds", "evidence"], rows), ""]


def _page(study: TablesStudy, payload, source, figures) -> str:
    res = study.result
    L = [banner(source)]
    L += ["# The paper's tables on the recordings", ""]
    L += [f"Dataset: {payload['dataset']['description']}.", ""]
    if res.missing:
        L += [f"**Missing folders** (their cells are empty): {', '.join('`' + m + '`' for m in res.missing)}.", ""]
    if payload.get("left_out"):
        L += ["**Partial evaluation (`--partial`)**: these recordings were left out; the cells below are "
              "computed without them.", ""] + [f"- {x}" for x in payload["left_out"]] + [""]
    if payload.get("no_rest"):
        L += ["**Recordings without an initial rest**: they move from their first samples (no stretch before the "
              "motion stays within what a still IMU shows, `calibration.still_bound`), so they are evaluated under "
              "RD only: their GC and GAC runs are not computed (each cell lists them among its failed runs), and "
              "their motion window runs from the first sample to where the gyro's spread falls within a still "
              "IMU's.", ""
              ] + [f"- {x}" for x in payload["no_rest"]] + [""]
    L += ["Errors are end-point errors in % of the travelled distance, mean over the runs (the paper's measure); "
          "`dist %` is `|estimated travelled distance - true distance|` in % of the distance. "
          "MoRPI cells are the `test` runs; INS cells all runs of the folder. `Δ` is ours minus paper in "
          "percentage points.", ""]
    L += ["Each recording has one motion window, used alike by the INS, MoRPI-A and MoRPI-G: it opens when the "
          "gyro's vibration rises above ten times its level in the detected initial rest window, after that "
          "window ends, and closes when the robot stops (`FieldData.activity`); the MoRPI heading starts at zero "
          "at its start. Each run in `result.json` carries its `rest_window_s` and `motion_window_s`.", ""]
    th = payload.get("thresholds")
    if th:
        sw = th["train_swings_deg"]
        L += [f"Detection thresholds set on the train runs only (`field.train_thresholds`): the rest detection's "
              f"accelerometer floor is {fmt(th['accel_floor_mps2'], 3)} m/s² (4 times the median, over "
              f"{len(th['train_rest_accel_std_mps2'])} train runs, of the largest accelerometer moving standard "
              f"deviation inside each run's gyro-only rest), and a run counts as periodic when its median heading "
              f"swing per period reaches {fmt(th['min_swing_deg'], 0)} deg (three quarters of the smallest swing "
              + (f"of the {len(sw)} train runs, {fmt(min(sw), 1)} deg" if sw else "the train runs show")
              + ", rounded down). The gyro thresholds are in noise sigmas of each recording's own rest. "
              f"A full period turns when its heading change exceeds {fmt(th['turn_deg'], 0)} deg (the `turns` "
              "heading reading, below).", ""]
    sel_txt = []
    seen = set()
    for m, s in res.selections.items():
        if id(s) in seen:
            continue
        seen.add(id(s))
        c = s.config
        sel_txt.append(f"- **{s.method}**: heading `{c.heading}` read from the `{c.heading_source}`, segments "
                       f"between `{c.segment}`, partial end steps "
                       f"`{c.ends}`, low-pass {fmt(c.cutoff_hz, 1)} Hz, prominence {c.prominence:g} of the "
                       f"signal range, least period {c.min_period_s:g} s (train leave-one-out error "
                       f"{fmt(s.score)} % over {s.n_train} train runs).")
    L += ["## Step rule (chosen on the train runs only)", "",
          "The readings and thresholds are picked by `field.select_config`: a coordinate search scored by the "
          "leave-one-out end-point error of the short-route train runs (GC); test folders never enter. "
          + ("One rule serves both methods (the paper's \"G_G is extracted in the same manner as G_A\"): the "
             "search is scored by the mean of both methods' train errors. "
             if res.rule == "joint" else
             "Each method gets its own rule: the search runs once per method on that method's train error. ")
          + "Of the two ways of choosing, the default is the one the nested train-only check below prefers.", ""]
    L += sel_txt + [""]
    pm = payload["other_rule"]
    def _within(cells):
        gc = [c for c in cells if c["table"] == "short_route" and c["calibration"] == "GC"
              and c["ours_percent"] is not None]
        return sum(abs(c["ours_percent"] - c["paper_percent"]) <= DEVIATION_PP for c in gc), len(gc)

    k_alt, n_alt = _within(pm["cells"])
    k_def, n_def = _within(payload["cells"])
    alt_name = "one rule for both methods" if pm["rule"] == "joint" else "a rule per method"
    L += [f"The other way of choosing, {alt_name} (`{pm['rule']}`), gives the table below. It is not the "
          f"default because the nested train-only check does not prefer it. Under it {k_alt} of {n_alt} short-route "
          f"GC cells fall within {DEVIATION_PP:g} pp of the paper (the default: {k_def} of {n_def}); it is shown "
          "for comparison only.", ""]
    L += ["\n".join(f"- {m}: `{v['config']}` (train LOO {fmt(v['train_loo_percent'])} %)"
                    for m, v in pm["step_rule"].items()), ""]
    L += [md_table(["table", "phone", "p2p", "method", "cal", "paper %", f"{pm['rule']} rule %", "dist %"],
                   [[c["table"], c["phone"], f"{c['p2p_m']:g} m", c["method"], c["calibration"],
                     fmt(c["paper_percent"]), fmt(c["ours_percent"]), fmt(c["distance_error_percent"])]
                    for c in pm["cells"] if c["calibration"] == "GC"])]
    nest = payload["step_rule_nested"]
    if nest["n_folds"]:
        L += ["**Nested check of that choice.** The train error above is measured on the runs each rule was "
              "chosen on, which favours the rule with more freedom. `field.nested_rule_comparison` holds out "
              "each train run in turn, sets the detection thresholds again without it (`field.fold_thresholds`: "
              "the accelerometer floor, the least swing and the least turn of the other train runs; "
              + _fold_threshold_note(nest) + "), repeats the whole search (per method, and joint, both heading "
              "sources) on the other train runs, and dead-reckons the held-out run with the rule found. Held-out "
              "error over "
              f"{nest['n_folds']} train runs: per method {fmt(nest['mean']['per_method'])} % "
              f"(MoRPI-A {fmt(nest['rules']['per_method']['MoRPI-A'])}, MoRPI-G "
              f"{fmt(nest['rules']['per_method']['MoRPI-G'])}), joint {fmt(nest['mean']['joint'])} % "
              f"(MoRPI-A {fmt(nest['rules']['joint']['MoRPI-A'])}, MoRPI-G {fmt(nest['rules']['joint']['MoRPI-G'])}); "
              f"joint minus per method {fmt(nest['difference_pp'])} ± {fmt(nest['difference_se_pp'])} pp "
              f"(standard error, paired over the held-out runs). The train runs prefer "
              f"`{nest['preferred']}`. The search without a held-out run finds the full-data rule in "
              + ", ".join(f"{fmt(100 * v, 0)} % ({m})" for m, v in nest["same_as_full"][res.rule].items())
              + f" of the folds ({res.rule}).", ""]
    for table, label in TABLES.items():
        cells = [c for c in res.cells if c.spec.table == table]
        L += [f"## `{table}` (paper: table `{label}`)", ""]
        rows = []
        for c in cells:
            s = c.spec
            rows.append([s.phone, "-" if s.p2p_m is None else f"{s.p2p_m:g} m", s.method, s.calibration,
                         fmt(s.paper_percent),
                         fmt(c.ours_percent) + (f" ± {fmt(c.ours_std_percent)}" if c.runs else ""),
                         fmt(c.distance_percent), fmt(c.ours_m), fmt(c.deviation_pp),
                         len(c.runs), fmt(c.gain, 4), c.missing or (f"{len(c.failed)} failed" if c.failed else "")])
        L += [md_table(["phone", "p2p", "method", "cal", "paper %", "ours %", "dist %", "ours m", "Δ pp", "runs",
                        "gain", "note"], rows)]
        L += ["<details><summary>per-run end-point errors [%]</summary>", ""]
        for c in cells:
            if c.runs:
                L += [f"- {c.spec.label}: "
                      + ", ".join(f"{Path(r.file).stem} {r.end_error_percent:.1f}" for r in c.runs)]
            for f in c.failed:
                L += [f"  - failed: {f}"]
        L += ["", "</details>", ""]
    comp = payload["comparison"]
    L += [f"## Method comparison, 6.3 m indoor route (paper: table `{comp['label']}`)", "",
          "Best calibration of each method; improvements in percentage points of the end-point error "
          "(the paper's arithmetic).", ""]
    rows = []
    for row in comp["rows"]:
        imp = "; ".join(f"vs {k}: paper {fmt(v['paper'])}, ours {fmt(v['ours'])}"
                        for k, v in row["improvement_pp"].items())
        rows.append([row["method"], fmt(row["paper_error_m"]), fmt(row["ours_error_m"]), row["cell"] or "-", imp])
    L += [md_table(["method", "paper m", "ours m", "our cell", "improvement pp"], rows)]
    L += _claims_section(study.claims)
    L += ["## Trained gains", "", "Per training set, method and calibration: mean and std over the train runs "
          "(each run's gain makes its summed steps equal the known distance). RD and GC gains coincide: GC "
          "removes a constant from omega_z and leaves f_y alone, which changes no peak and no max - min; "
          "calibration acts on MoRPI through the heading only.", ""]
    L += [md_table(["train set", "method", "cal", "mean", "std", "runs", "left out"],
                   [[g["train_set"], g["method"], g["calibration"], fmt(g["mean"], 4), fmt(g["std"], 4),
                     len(g["per_run"]), "; ".join(g["skipped"])] for g in payload["gains"]])]
    L += ["## The paper's open readings (short route)", "",
          "Each reading of Δψ (heading), step boundaries and partial end steps, other tunables as selected; "
          "mean end-point error [%] of the test runs (paper's value in the header).", ""]
    heads = ["method", "cal", "heading", "segment", "ends"]
    first = payload["readings"][0]["cells"] if payload["readings"] else []
    heads += [f"{x['phone']} {x['p2p_m']:g} m" for x in first]
    rows = []
    for r in payload["readings"]:
        mark = " **(selected)**" if r["selected"] else ""
        rows.append([r["method"], r["calibration"], r["heading"] + mark, r["segment"], r["ends"]]
                    + [f"{fmt(x['ours_percent'])} (paper {fmt(x['paper_percent'])})" for x in r["cells"]])
    L += [md_table(heads, rows)]
    closest = _closest_reading(payload["readings"])
    if closest:
        L += ["Mean |ours - paper| over the three GC cells of each method: "
              + "; ".join(f"{m}: closest to the paper `{r['heading']}/{r['segment']}/{r['ends']}` "
                          f"({fmt(d)} pp), selected rule {fmt(sd)} pp" for m, (r, d, sd) in closest.items()) + ".", ""]
    L += ["`change` cannot follow a turn (the L route ends 10 m sideways), so it is not a candidate of the search; "
          "`turns`, the same reading with the turns added, is (see the section on a heading that follows turns).", ""]
    sens = payload["rule_sensitivity"]
    if sens:
        L += ["## How much the step rule moves the short-route cells", "",
              "Every rule the search scored, best train error first: its train leave-one-out error, the paired "
              "difference to the selected rule over the same train runs (± standard error), and the three "
              "short-route GC test cells with gains trained under it. The search sees the train columns only. "
              f"Rules within {TRAIN_SE_BAND:g} standard errors of the selected one (marked ≈) are ones the train "
              "runs cannot tell apart.", ""]
        for m in MORPI_METHODS:
            mine = [r for r in sens if r["method"] == m]
            if not mine:
                continue
            heads = ["heading", "segment", "ends", "cut-off Hz", "prominence", "least period s", "train LOO %",
                     "Δ train pp"] + [f"{x['phone']} {x['p2p_m']:g} m (paper {fmt(x['paper_percent'])})"
                                      for x in mine[0]["cells"]]
            rows = []
            for r in mine:
                c = r["config"]
                d = ("-" if r["train_difference_pp"] is None else
                     f"{fmt(r['train_difference_pp'])} ± {fmt(r['train_difference_se_pp'])}"
                     + (" ≈" if _indistinct(r) and not r["selected"] else ""))
                rows.append([c["heading"] + (" **(selected)**" if r["selected"] else ""), c["segment"], c["ends"],
                             fmt(c["cutoff_hz"], 1), f"{c['prominence']:g}", f"{c['min_period_s']:g}",
                             fmt(r["train_loo_percent"]), d] + [fmt(x["ours_percent"]) for x in r["cells"]])
            L += [f"**{m}**", "", md_table(heads, rows)]
        lines = []
        for m in MORPI_METHODS:
            parts = []
            for phone, p2p in dict.fromkeys((x["phone"], x["p2p_m"]) for r in sens for x in r["cells"]):
                rng = _sensitivity_range(sens, m, phone, p2p)
                if rng is not None:
                    parts.append(f"{phone} {p2p:g} m {fmt(rng[0])}–{fmt(rng[1])} %")
            if parts:
                lines.append(f"- {m}: " + ", ".join(parts))
        if lines:
            L += [f"Range of each cell over the rules within {TRAIN_SE_BAND:g} standard errors of the selected one:",
                  ""] + lines + [""]
    L += _heading_section(payload)
    L += _turn_section(payload)
    L += ["## INS integration span", "", "The INS cells integrated over the robot's motion (default) and over the "
          "whole recording (rests included).", ""]
    L += [md_table(["table", "method", "cal", "paper %", "motion span %", "full recording %"],
                   [[r["table"], r["method"], r["calibration"], fmt(r["paper_percent"]), fmt(r["motion_span_percent"]),
                     fmt(r["full_span_percent"])] for r in payload["ins_full_span"]])]
    L += ["## INS started from the measured tilt", "",
          "The paper's GAC assumes a level phone and removes the whole rest specific force minus gravity as "
          "accelerometer bias. Here the 3D INS is started instead from the roll and pitch the rest specific force "
          "shows (`strapdown.coarse_level`, GC gyro, accelerometer left as it is). Where the phone rests tilted, "
          "as on the L route's slope, the level assumption turns gravity into a false acceleration once the tilt "
          "changes. A further reading, not a cell of the paper.", ""]
    L += [md_table(["table", "phone", "paper GAC %", "ours GAC %", "ours GC + tilt at rest %",
                    "mean tilt at rest [deg]", "runs"],
                   [[r["table"], r["phone"], fmt(r["paper_gac_percent"]), fmt(r["gac_percent"]),
                     fmt(r["leveled_percent"]), fmt(r["mean_rest_tilt_deg"], 1), r["runs"]]
                    for r in payload["ins_leveled"]])]
    far = [c for c in res.cells if c.runs and abs(c.deviation_pp) > DEVIATION_PP]
    other = {(c["table"], c["phone"], c["p2p_m"], c["method"], c["calibration"]): c["ours_percent"]
             for c in payload["other_rule"]["cells"] if c["ours_percent"] is not None}
    L += [f"## Cells further than {DEVIATION_PP} pp from the paper", "",
          "What was tried for every cell, whatever its distance to the paper: the paper's three open readings "
          "(heading, step boundaries, partial end steps; readings table), one step rule for both methods or one "
          "per method (step-rule section), the INS over the motion or over the whole recording (integration-span "
          "table). Only train runs choose among them; the paper's values never do.", ""]
    if not far:
        L += ["None.", ""]
    for c in far:
        L += [f"- **{c.spec.label}**: paper {fmt(c.spec.paper_percent)}, ours {fmt(c.ours_percent)} "
              f"(Δ {fmt(c.deviation_pp)} pp). {_explain(c, res, study.cell_notes, other, payload['rule_sensitivity'])}"]
    L += [""]
    if figures:
        L += ["## Figures", ""]
        captions = {"recording_line.png": "Straight-line recording: specific force and angular rate; rest window "
                                          "shaded, motion span dashed.",
                    "recording_periodic.png": "Periodic recording: rest window shaded, MoRPI-G step boundaries "
                                              "marked on omega_z.",
                    "ins_straight.png": "3D/2D INS with RD and GAC on a straight-line run.",
                    "ins_l_shape.png": "3D/2D INS with RD and GAC on an L-route run.",
                    "morpi_paths.png": "MoRPI-A and MoRPI-G (GC) paths of every test run against the true route."}
        for f in figures:
            L += [f"![{f}]({f})", "", captions.get(f, ""), ""]
    L += ["## MoRPI-aided INS", "",
          "The same MoRPI cells with the MoRPI steps as measurements of a closed-loop error-state filter around "
          "the 3D INS (non-holonomic and rest updates, smoothing; tunables chosen on the train runs only), beside "
          "MoRPI alone and INS alone, with the contribution of each aid, are the aided section of the report: "
          "[aided/README.md](../aided/README.md) (written by `morpi aided --data DIR` or `morpi report`).", ""]
    return "\n".join(L)


# --------------------------------------------------------------------------- JSON

def _cell_json(c: Cell) -> dict:
    s = c.spec
    return {
        "table": s.table, "paper_label": TABLES[s.table], "phone": s.phone, "p2p_m": s.p2p_m,
        "method": s.method, "calibration": s.calibration, "paper_percent": s.paper_percent,
        "ours_percent": c.ours_percent, "ours_std_percent": c.ours_std_percent, "ours_error_m": c.ours_m,
        "distance_error_percent": c.distance_percent, "deviation_pp": c.deviation_pp,
        "route": s.route, "split": s.split,
        "train_set": None if s.train is None else f"{s.train[0]}/{s.train[1]}/train",
        "gain": c.gain, "n_runs": len(c.runs), "failed": list(c.failed), "missing": c.missing,
        "runs": [{"file": r.file, "end_point_m": list(r.end_point), "end_error_m": r.end_error_m,
                  "end_error_percent": r.end_error_percent, "distance_m": r.distance_m,
                  "distance_error_percent": r.distance_error_percent, "n_steps": r.n_steps,
                  "rest_window_s": None if r.rest_window_s is None else list(r.rest_window_s),
                  "motion_window_s": None if r.motion_window_s is None else list(r.motion_window_s)}
                 for r in c.runs],
    }


@renamed_keywords(source="data_source")
def result_json(study: TablesStudy, data_source=None) -> dict:
    """The section's JSON contract (cells, gains, selection, comparison, alternatives), read from `study`.

    Needs a :class:`morpi_filters.evaluate.TablesStudy` of a dataset, so there is no example.

    Parameters
    ----------
    study : evaluate.TablesStudy
        What :func:`morpi_filters.evaluate.tables_study` computed.
    data_source : results.DataSource, optional
        The dataset (its root and whether it is synthetic).

    Returns
    -------
    dict
        ``dataset`` (what the recordings are, never where they lie:
        :meth:`morpi_filters.fetch.DatasetIdentity.as_json`; None without a
        data_source), ``synthetic``, ``missing_folders``, ``cells``,
        ``gains`` (per training set: ``train_set``, ``phone``, ``route``,
        ``method``, ``calibration``, ``mean``, ``std``, ``per_run``, ``files``,
        ``skipped``, ``unit``), ``step_rule``, ``comparison``, ``readings``,
        ``ins_full_span``, ``other_rule``, ``step_rule_nested``,
        ``rule_sensitivity``, ``ins_leveled``, ``claims``, ``thresholds`` and
        ``heading_readings``.
    """
    result = study.result
    return {
        "dataset": None if data_source is None or data_source.root is None else dataset_identity(
            data_source.root, synthetic=data_source.synthetic, seed=data_source.seed).as_json(),
        "synthetic": bool(data_source.synthetic) if data_source is not None else False,
        "missing_folders": list(result.missing),
        "cells": [_cell_json(c) for c in result.cells],
        "gains": [{"train_set": f"{g.phone}/{g.route}/train", "phone": g.phone, "route": g.route,
                   "method": g.method, "calibration": g.calibration, "mean": g.mean, "std": g.std,
                   "per_run": list(g.per_run), "files": list(g.files), "skipped": list(g.skipped),
                   "unit": "m/(m/s^2)^(1/4)" if g.method == "MoRPI-A" else "m/(rad/s)^(1/4)"}
                  for g in result.gains],
        "step_rule": {m: {"config": rule_json(s.config), "train_loo_percent": s.score, "n_train_runs": s.n_train,
                          "trials": [{"config": rule_json(c), "train_loo_percent": v} for c, v in s.trials]}
                      for m, s in result.selections.items()},
        "comparison": study.comparison,
        "readings": list(result.readings),
        "ins_full_span": study.ins_full_span,
        "other_rule": study.other_rule,
        "step_rule_nested": _nested_json(study.nested),
        "rule_sensitivity": study.rule_sensitivity,
        "ins_leveled": study.ins_leveled,
        "claims": list(study.claims),
        "thresholds": _thresholds_json(result),
        "heading_readings": study.heading_readings,
        "turn_reading": study.turn_reading,
    }


#: Keys of the nested check's folds renamed in 0.2 (old -> new); the old key follows the new one for one release.
_FOLD_ALIASES = {"accel_floor": "accel_floor_mps2"}


def _nested_json(nested):
    """The nested train-only check as the JSON shows it: each fold's threshold keys with their units."""
    if not isinstance(nested, dict) or not isinstance(nested.get("folds"), list):
        return nested
    folds = [with_aliases({_FOLD_ALIASES.get(k, k): v for k, v in f.items()}, _FOLD_ALIASES) if isinstance(f, dict)
             else f for f in nested["folds"]]
    return {**nested, "folds": folds}


def _thresholds_json(result) -> dict | None:
    """The detection thresholds the train runs set (:func:`morpi_filters.field.train_thresholds`)."""
    if result.data is None:
        return None
    t = result.data.thresholds
    return {"accel_floor_mps2": t.accel_floor, "min_swing_deg": t.min_swing_deg,
            "train_rest_accel_std_mps2": list(t.rest_std), "train_swings_deg": list(t.swings_deg),
            "train_files": list(t.files), "turn_deg": t.turn_deg,
            "train_period_changes_deg": list(t.period_changes_deg)}



# --------------------------------------------------------------------------- explanations

def _closest_reading(readings) -> dict:
    """Per method: (the GC reading closest to the paper, its mean |deviation|, the selected rule's) [pp]."""
    out = {}
    for m in MORPI_METHODS:
        rows = [r for r in readings if r["method"] == m and r["calibration"] == "GC"
                and all(x["ours_percent"] is not None for x in r["cells"])]
        if not rows:
            continue
        dev = [float(np.mean([abs(x["ours_percent"] - x["paper_percent"]) for x in r["cells"]])) for r in rows]
        i = int(np.argmin(dev))
        sel = [d for r, d in zip(rows, dev) if r["selected"]]
        out[m] = (rows[i], dev[i], sel[0] if sel else float("nan"))
    return out


#: Step rules whose train error is within this many paired standard errors of the selected one
#: count as ones the train runs cannot tell apart (sensitivity section of the page).
TRAIN_SE_BAND = 2.0


def _indistinct(row: dict) -> bool:
    d, se = row["train_difference_pp"], row["train_difference_se_pp"]
    return d is not None and se is not None and d <= TRAIN_SE_BAND * se


def _sensitivity_range(rows, method, phone, p2p) -> tuple | None:
    """(least, greatest, number of rules) of a short-route GC cell over the rules the train runs cannot tell apart."""
    vals = [x["ours_percent"] for r in rows if r["method"] == method and _indistinct(r)
            for x in r["cells"] if x["phone"] == phone and x["p2p_m"] == p2p and x["ours_percent"] is not None]
    n = len({tuple(sorted(r["config"].items())) for r in rows if r["method"] == method and _indistinct(r)})
    return (min(vals), max(vals), n) if vals else None


def _explain(c, res, notes: dict, other: dict | None = None, sens: list | None = None) -> str:
    s = c.spec
    side = "above" if c.deviation_pp > 0 else "below"
    if s.method in INS_METHODS:
        leak = ""
        n = notes.get(s.label)
        if n is not None and "tilt_deg" in n:
            leak = (f" Measured here: the 3D solution tracks a mean tilt of {n['tilt_deg']:.2f} deg about y "
                    f"during the motion (the body pitching while it drives); the planar INS integrates that "
                    f"share of gravity in f_x as forward acceleration, {n['tilt_m']:.2f} m on average "
                    f"after double integration, against a mean along-track overshoot of {n['along_m']:.2f} m of the "
                    f"planar runs. This is why the planar INS is worse than the 3D one on these recordings, "
                    f"the opposite of the paper's ordering after GAC.")
        return (f"Ours is {side} the paper. INS drift grows with the square of time through the accelerometer "
                f"bias residual and the tilt, so the number depends on where the integration starts and stops "
                f"(tried: the motion span, default, and the whole recording, both in the integration-span table) "
                f"and on the unknown details of the paper's mechanization; the INS is not tuned to the paper's "
                f"values.{leak}")
    drift, final = notes[s.label]["heading_drift_deg"], notes[s.label]["heading_final_deg"]
    if s.calibration == "RD" and res.selections[s.method].config.heading in ("change", "turns"):
        h = res.selections[s.method].config.heading
        return (f"Ours is {side} the paper. Raw gyro: the z bias turns the integrated heading by {drift:.0f} deg on "
                f"average over the motion, but the chosen `{h}` reading takes each step's own heading change"
                + (" and only the turns" if h == "turns" else "")
                + f", so that drift hardly enters; the distance error is {c.distance_percent:.2f} %. The paper's "
                "RD errors are above its GC errors, as a heading accumulated from the raw gyro gives.")
    if s.calibration == "RD":
        alt_txt = ""
        cfg = res.selections[s.method].config
        alt = [r for r in res.readings if r["method"] == s.method and r["calibration"] == "RD"
               and r["heading"] == "change" and r["segment"] == cfg.segment and r["ends"] == cfg.ends]
        if alt and s.table == "short_route":
            v = next((x["ours_percent"] for x in alt[0]["cells"] if x["phone"] == s.phone and x["p2p_m"] == s.p2p_m),
                     None)
            if v is not None:
                alt_txt = (f" Tried: the heading-change reading (the heading change inside each step, blind to a "
                           f"constant bias over a whole run) gives {v:.2f} % here, but it cannot follow a turn "
                           f"(the `turns` reading adds the turns; section on a heading that follows turns).")
        return (f"Ours is {side} the paper. Raw gyro: the z bias turns into a heading drift of {drift:.0f} deg on "
                f"average over the motion, which bends the dead-reckoned path; the distance error is only "
                f"{c.distance_percent:.2f} %.{alt_txt} The paper's RD errors are close to its GC errors, which a "
                f"heading accumulated from the raw gyro cannot give on these recordings.")
    if s.table == "long_route":
        return (f"Ours is {side} the paper. Outdoor runs with the indoor gains: the distance error is "
                f"{c.distance_percent:.2f} %, the rest is heading (the GC heading ends {final:.0f} deg off the "
                f"route's direction on average, which moves the end point sideways). Tried: the other way of choosing "
                f"the step rule (table above) and the readings of the paper on the short route; none is chosen on test runs.")
    if s.table == "morpi_l_shape":
        return (f"Ours is {side} the paper. L route with the s6 indoor gains: distance error "
                f"{c.distance_percent:.2f} %, the GC heading ends {final:.0f} deg off the true 90 deg turn on "
                f"average. The paper does not state its peak rule; ours was chosen on the indoor train runs and the "
                f"readings table shows how much the rule alone moves a cell (several pp).")
    alt = (other or {}).get((s.table, s.phone, s.p2p_m, s.method, s.calibration))
    alt_txt = (f" With one step rule for both methods (step-rule section) this cell is {alt:.2f} %."
               if alt is not None else "")
    rng = _sensitivity_range(sens or [], s.method, s.phone, s.p2p_m)
    rng_txt = (f" The {rng[2]} step rule(s) whose train error is within {TRAIN_SE_BAND:g} standard errors of the "
               f"selected one give this cell {rng[0]:.2f} to {rng[1]:.2f} % (sensitivity table)."
               if rng is not None else "")
    return (f"Ours is {side} the paper. Step rule chosen on the train runs (leave-one-out), not on the test runs; "
            f"distance error {c.distance_percent:.2f} %.{alt_txt}{rng_txt} Other readings are in the readings table.")
