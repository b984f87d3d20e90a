"""Entry points return what their docstrings promise (keys, tuple shapes)."""
from __future__ import annotations

import numpy as np
import pytest

from morpi_filters import simulate, steps, symbolic, units


def test_closed_form_errors_takes_the_documented_keys():
    params = {"dv0_mps": [0.01] * 3, "accel_bias_mps2": [0.02] * 3, "gyro_bias_radps": [1e-3] * 3, "g_mps2": 9.81}
    t = np.array([0.0, 1.0, 2.0])
    assert symbolic.closed_form_errors(params, t, "INS-3D").shape == (3,)
    assert symbolic.closed_form_errors(params, t, "INS-3D position").shape == (3, 3)
    assert symbolic.closed_form_errors(params, t, "INS-2D position").shape == (3, 2)


def test_train_gain_returns_a_flat_triple():
    rng = np.random.default_rng(0)
    traj = simulate.sine(6.3, p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0)
    data = simulate.imu(traj, units.LSM6DSL, rng, bias_scale=(0.0, 0.0))
    s = steps.extract_steps(data.recording(), "MoRPI-G", steps.DEFAULT_CONFIGS["MoRPI-G"])
    out = steps.train_gain([s, s], [6.3, 6.3])
    mean, std, per_run = out
    assert len(out) == 3 and isinstance(mean, float) and isinstance(std, float)
    assert per_run.shape == (2,) and std == 0.0 and mean == per_run[0]



def test_no_two_public_functions_share_a_name():
    """A function name exported by two modules is one function (one vocabulary across the package)."""
    import importlib
    import inspect
    import pkgutil

    import morpi_filters

    seen = {}
    for info in pkgutil.walk_packages(morpi_filters.__path__, "morpi_filters."):
        module = importlib.import_module(info.name)
        for name in getattr(module, "__all__", ()):
            obj = getattr(module, name, None)
            if inspect.isfunction(obj) or inspect.isclass(obj):
                other = seen.setdefault(name, (info.name, obj))
                assert other[1] is obj, f"{name}: {other[0]} and {info.name} define different things"


def test_a_recording_by_path_knows_its_labels_and_truth(tmp_path):
    import warnings

    import pytest

    from morpi_filters import dataset as ds

    t = np.arange(300) * 0.01
    rec = ds.Recording(time=t, f=np.tile([0.0, 0.0, 9.8], (300, 1)), omega=np.zeros((300, 3)), source="x")
    inside = tmp_path / "s6" / "L_shape" / "test" / "3.csv"
    inside.parent.mkdir(parents=True)
    ds.write_csv(inside, rec)
    got, truth = ds.load_recording(inside)
    assert (got.phone, got.route, got.split) == ("s6", "L_shape", "test") and truth.name == "L_shape"
    outside = tmp_path / "mine.csv"
    ds.write_csv(outside, rec)
    with pytest.warns(UserWarning, match="not in the MoRPI layout"):
        got, truth = ds.load_recording(outside)
    assert got.phone is None and truth is None
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ds.load_recording(inside)


def test_a_track_measures_its_error_against_a_route():
    from morpi_filters import dataset as ds

    traj = simulate.sine(6.3, p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0)
    data = simulate.imu(traj, units.LSM6DSL, np.random.default_rng(1), bias_scale=(0.0, 0.0))
    s = steps.extract_steps(data.recording(), "MoRPI-G", steps.DEFAULT_CONFIGS["MoRPI-G"])
    track = steps.morpi_track(s, 1.0)
    truth = ds.route("short_distance")
    assert track.error(truth) == track.error("short_distance")
    # the norm and hypot round differently in the last bit
    assert track.error(truth) == pytest.approx(float(np.hypot(*(track.end_point - truth.end_point_m))), rel=1e-15)


# ----------------------------------------------------------------------------- promised keys and shapes

def _returns(func) -> str:
    """The Returns section of a numpydoc docstring."""
    import inspect
    import re

    doc = inspect.getdoc(func) or ""
    m = re.search(r"Returns\n-------\n(.*?)(?:\n\n[A-Z][A-Za-z ]+\n-+\n|\Z)", doc, re.S)
    assert m, f"{func.__qualname__}: no Returns section"
    return m.group(1)


def _documented_keys(func) -> set:
    """Every ``key`` (double-backticked, optionally quoted name) the Returns section promises."""
    import re

    return {m.group(1) for m in re.finditer(r'``"?([A-Za-z][A-Za-z0-9_\-]*)"?``', _returns(func))}


def _keys(obj) -> set:
    """Keys of a dict, of a list of dicts, and of the dicts inside them (two levels)."""
    items = obj if isinstance(obj, list) else [obj]
    out = set()
    for d in items:
        out |= set(d)
        for v in d.values():
            if isinstance(v, dict):
                out |= set(v)
    return out


def _shape(func) -> tuple:
    """The first ``shape (...)`` the Returns section promises, as a tuple of strings."""
    import re

    m = re.search(r"shape \(([^)]*)\)", _returns(func))
    assert m, f"{func.__qualname__}: no shape in Returns"
    return tuple(p.strip() for p in m.group(1).split(",") if p.strip())


def test_dict_returns_hold_exactly_the_documented_keys():
    from morpi_filters import curves, params
    from morpi_filters import montecarlo as mc

    p = params.load_params()
    cc = curves.compute_curves(curves.case_from_params(p), times=[1.0, 2.0], runs=20, nonlinear_runs=0,
                               rng=np.random.default_rng(0))
    got = cc.at_eval_times()
    doc = _documented_keys(curves.CaseCurves.at_eval_times)
    assert set(got) <= doc and {"sigma_m", "rms_closed_form_m", "closed_form_error_m", "mc_rms_m"} <= set(got)
    assert all(set(v) == set(curves.CURVE_METHODS) for k, v in got.items() if k != "nonlinear_mc_rms_m")
    r = mc.run_study(30, 0, mc.StudyConfig(training_runs=20, gains=(mc.GainError("g", 0.05, 0.01),)))
    checks = mc.distance_law_check(r)
    assert _keys(checks) == _documented_keys(mc.distance_law_check)
    stats = mc.final_statistics(r)
    assert set(stats) == set(mc.METHODS)
    assert all(set(v) == {"mean", "std", "median", "p95"} for v in stats.values())


def test_array_returns_have_the_documented_shapes():
    from morpi_filters import curves, error_model, eskf, params
    from morpi_filters import montecarlo as mc

    p = params.load_params()
    times = [1.0, 2.0, 3.0]
    for method in curves.CURVE_METHODS:
        assert _shape(curves.horizontal_sigma) == ("m",)
        assert curves.horizontal_sigma(p, times, method).shape == (len(times),)
    case = curves.case_from_params(p)
    assert _shape(curves.case_mean_square) == ("n",) and curves.case_mean_square(case, times, "INS-2D").shape == (3,)
    C, f = error_model.paper_trajectory(9.81)
    for fn, args, want in ((error_model.system_matrix, (C, f), (15, 15)), (error_model.noise_coupling, (C,), (15, 12)),
                           (eskf.initial_covariance, (0.1, 0.01, 0.001), (15, 15))):
        assert tuple(int(d) for d in _shape(fn)[-2:]) == want
        assert fn(*args).shape == want
    assert "(length_m, speed_mps, duration_s)" in (mc.StudyConfig.motion.__doc__ or "")
    assert len(mc.StudyConfig().motion()) == 3
    lo, hi = eskf.chi2_band(2, 100)
    assert "(lo, hi)" in _returns(eskf.chi2_band) and lo < 2 < hi


def test_analysis_scripts_and_the_tutorial_use_public_names_only():
    import ast
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    scripts = sorted((root / "analysis").glob("*.py")) + [root / "docs" / "tutorial.py"]
    assert len(scripts) >= 6
    for path in scripts:
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("morpi_filters"):
                assert not any(p.startswith("_") for p in node.module.split(".")), (path.name, node.module)
                assert not any(a.name.startswith("_") for a in node.names), (path.name, node.lineno)
            if isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__"):
                raise AssertionError(f"{path.name}:{node.lineno}: private name {node.attr}")


# ----------------------------------------------------------------------------- numpydoc sections

#: Modules whose public functions must carry complete numpydoc sections (issue 13, item 6).
_SECTIONED_MODULES = ("montecarlo._batch_ins", "assessment", "calibration", "cli", "curves", "dataset", "error_model",
                      "fetch", "parallel", "params", "steps", "field", "evaluate", "eskf", "symbolic", "manifest", "foreign")
#: Public functions of those modules without an Examples section, and why.
_NO_EXAMPLE = {
    "assessment.fit_paper_numbers": "a bounded least-squares fit of several seconds (tests/test_assessment.py runs it)",
    "assessment.write_fitted_params": "runs fit_paper_numbers (seconds) and writes the committed parameter file",
    "curves.curves_study": "three cases with the default Monte Carlo sizes (seconds); compute_curves shows one case",
    "field.train_thresholds": "reads the train runs of the MoRPI field dataset",
    "field.select_config": "scores dozens of step rules on the field dataset's train runs (seconds)",
    "field.nested_rule_comparison": "repeats select_config once per held-out train run of the field dataset",
    "field.fold_thresholds": "needs the thresholds of a dataset's train runs (field recordings)",
    "field.trained_gain": "needs a folder of train recordings of the field dataset",
    "field.train_summary": "reads the train sets of a FieldData",
    "field.held_out_errors": "reads the train sets of a FieldData",
    "field.held_out_score": "reads the train sets of a FieldData",
    "field.set_gain": "needs the step sums of a dataset's train runs (a FieldData)",
    "evaluate.evaluate_tables": "computes every table cell from the field dataset (minutes)",
    "evaluate.tables_study": "runs the whole tables section on the field dataset (minutes)",
    "evaluate.training_gain_spread": "trains the gains on the field dataset's train runs",
    "evaluate.rule_sensitivity": "takes a TablesResult of the field dataset",
    "evaluate.comparison": "takes a TablesResult of the field dataset",
    "evaluate.ins_full_span": "takes a TablesResult of the field dataset",
    "evaluate.ins_leveled": "takes a TablesResult of the field dataset",
    "evaluate.other_rule": "re-evaluates the tables on the field dataset",
    "evaluate.check_cells": "takes a TablesResult of the field dataset",
    "evaluate.dataset_problems": "loads every recording of the field dataset",
    "evaluate.heading_readings": "re-evaluates the tables twice on the field dataset",
    "evaluate.turn_reading": "re-evaluates the tables once per heading reading on the field dataset",
    "evaluate.short_route_sets": "reads the train sets of a FieldData",
}


def _sections(doc: str) -> dict:
    """numpydoc section title -> body, of a docstring already dedented by inspect.getdoc."""
    import re

    parts = re.split(r"^([A-Z][A-Za-z ]+)\n-+\n", doc, flags=re.M)
    return {parts[i]: parts[i + 1] for i in range(1, len(parts) - 1, 2)}


def _documented_parameters(body: str) -> set:
    """Names of the entries of a Parameters section (``a, b : type`` documents a and b)."""
    names = set()
    for line in body.splitlines():
        if line and not line[0].isspace():
            names |= {n.strip().lstrip("*") for n in line.split(" : ")[0].split(",")}
    return names


def _defined_in(func, module) -> bool:
    """Whether `func` is defined in `module` or, for a package, in one of its modules (re-exported)."""
    return func.__module__ == module.__name__ or (hasattr(module, "__path__")
                                                 and func.__module__.startswith(module.__name__ + "."))


def _public_functions(modules):
    import importlib
    import inspect

    for short in modules:
        module = importlib.import_module(f"morpi_filters.{short}")
        for name in module.__all__:
            obj = getattr(module, name)
            if inspect.isfunction(obj) and _defined_in(obj, module):
                yield f"{short}.{name}", obj


def test_public_functions_have_parameters_returns_and_examples():
    import inspect

    checked, problems = 0, []
    for qual, func in _public_functions(_SECTIONED_MODULES):
        checked += 1
        sections = _sections(inspect.getdoc(func) or "")
        params = {p.name for p in inspect.signature(func).parameters.values()}
        if params:
            got = _documented_parameters(sections.get("Parameters", ""))
            if got != params:
                problems.append(f"{qual}: Parameters documents {sorted(got)}, the signature has {sorted(params)}")
        if not ({"Returns", "Yields"} & set(sections)):
            problems.append(f"{qual}: no Returns (or Yields) section")
        if "Examples" not in sections and qual not in _NO_EXAMPLE:
            problems.append(f"{qual}: no Examples section")
        if "Examples" in sections and qual in _NO_EXAMPLE:
            problems.append(f"{qual}: has Examples now; remove it from _NO_EXAMPLE")
    assert checked >= 60, checked
    assert not problems, "\n".join(problems)


# ----------------------------------------------------------------------------- numpydoc sections (studies, navigation and pages)

#: Modules whose public functions must document Parameters and Returns (or Yields). A module without
#: ``__all__`` (``aided``, ``report.aided``) counts its functions whose names do not start with "_".
_STUDY_PAGE_MODULES = (
    "field_aided", "montecarlo", "montecarlo.config", "montecarlo.engine", "montecarlo.training", "montecarlo.drift",
    "montecarlo.pages", "steps.rules", "steps.prepare", "steps.extract", "steps.headings",
    "steps.reckon", "outputs", "results", "units", "simulate", "strapdown", "synthetic", "aided", "errors",
    "resources", "report.aided", "report.assessment", "report.calibration", "report.common", "report.curves",
    "report.index", "report.montecarlo", "report.plots", "report.tables", "field_aided.inputs",
    "field_aided.baselines", "field_aided.tuning", "field_aided.significance", "field_aided.ablation",
    "field_aided.study",
)

#: Functions allowed to lack a section, with the reason. Empty: every function has its sections.
_STUDY_PAGE_EXCEPTIONS: dict = {}


def _study_page_public_functions():
    """(module name, function name, function) of every public function defined in the modules above."""
    import importlib
    import inspect

    for short in _STUDY_PAGE_MODULES:
        module = importlib.import_module(f"morpi_filters.{short}")
        names = getattr(module, "__all__", None)
        if names is None:
            names = [n for n in vars(module) if not n.startswith("_")]
        for name in names:
            obj = getattr(module, name)
            func = inspect.unwrap(obj) if callable(obj) else obj        # functools.lru_cache wrappers too
            if inspect.isfunction(func) and _defined_in(func, module):
                yield module.__name__, name, func


def test_public_functions_of_the_study_and_page_modules_have_parameters_and_returns():
    """Every public function of these modules has numpydoc Parameters (when it takes any) and Returns
    (or Yields) sections, and its Parameters name exactly the signature's parameters."""
    import inspect

    from numpydoc.docscrape import FunctionDoc

    seen, problems = 0, []
    for mod, name, func in _study_page_public_functions():
        seen += 1
        key = f"{mod}.{name}"
        if key in _STUDY_PAGE_EXCEPTIONS:
            continue
        doc = FunctionDoc(func)
        params = [p for p in inspect.signature(func).parameters.values()]
        wanted = {("**" if p.kind is p.VAR_KEYWORD else "*" if p.kind is p.VAR_POSITIONAL else "") + p.name
                  for p in params}
        documented = {n.strip() for p in doc["Parameters"] for n in p.name.split(",")}
        if params and not doc["Parameters"]:
            problems.append(f"{key}: no Parameters section")
        elif documented != wanted:
            problems.append(f"{key}: Parameters document {sorted(documented)}, the signature has {sorted(wanted)}")
        if not (doc["Returns"] or doc["Yields"]):
            problems.append(f"{key}: no Returns or Yields section")
    assert seen >= 85, seen          # 88 when written: the modules' public functions (a drop means the discovery broke)
    assert not problems, "\n".join(problems)
    assert set(_STUDY_PAGE_EXCEPTIONS) <= {f"{m}.{n}" for m, n, _ in _study_page_public_functions()}
