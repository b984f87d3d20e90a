"""The dataset evaluation as pandas tables: ``DatasetEvaluation.table`` and ``group_table`` against the JSON that
``morpi evaluate --dataset FILE --json`` writes on the same files, and the entry point ``dataset_eval.evaluate``."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from morpi_filters.cli import main
from morpi_filters.dataset_eval import METRICS, ROW_LABELS, evaluate
from morpi_filters.errors import ParameterError
from morpi_filters.foreign import LAYOUTS, write_foreign_dataset
from morpi_filters.manifest import load_dataset
from morpi_filters.results import JSON_DIGITS, round_significant

#: Route truth over three groups with train and test runs (MoRPI rows, path_rmse_m null), and a NED truth track.
CASES = ("groups", "truth-ned")


@pytest.fixture(scope="module", params=CASES)
def case(request, tmp_path_factory):
    """(manifest, the command's JSON read back from its file)."""
    root = tmp_path_factory.mktemp(request.param)
    ds = write_foreign_dataset(root / "data", LAYOUTS[request.param], seed=5)
    js = root / "result.json"
    assert main(["evaluate", "--dataset", str(ds.manifest), "--json", str(js)]) == 0
    return ds.manifest, json.loads(js.read_text())


def _same(key, cell, value) -> bool:
    """A DataFrame cell against the JSON's value: a metric's null is NaN, a number equal at the JSON's precision,
    a label (``estimate`` null: None) as it is."""
    if hasattr(cell, "item"):
        cell = cell.item()
    if key not in METRICS:
        return type(cell) is type(value) and cell == value
    if value is None:
        return isinstance(cell, float) and math.isnan(cell)
    return isinstance(cell, float) and round_significant(cell, JSON_DIGITS) == value


def test_the_table_holds_the_json_rows_cell_by_cell(case):
    manifest, cli = case
    table = evaluate(manifest).table()
    rows = cli["recordings"]
    assert rows and len(table) == len(rows)
    assert list(table.columns) == [k for k in rows[0] if k != "track_file"] == list(ROW_LABELS + METRICS)
    for i, row in enumerate(rows):
        got = table.iloc[i]
        bad = [k for k in table.columns if not _same(k, got[k], row[k])]
        assert not bad, (i, {k: (got[k], row[k]) for k in bad})


def test_metric_columns_are_float64_with_nan_where_the_json_has_null(case):
    manifest, cli = case
    table = evaluate(manifest).table()
    assert all(str(table[k].dtype) == "float64" for k in METRICS), table.dtypes
    nulls = np.array([[row[k] is None for k in METRICS] for row in cli["recordings"]])
    np.testing.assert_array_equal(table[list(METRICS)].isna().to_numpy(), nulls)
    # the route dataset has no path error at all; the track dataset has one on every row
    assert nulls[:, METRICS.index("path_rmse_m")].all() == (cli["recordings"][0]["path_rmse_m"] is None)


def test_the_group_table_holds_the_json_group_means(case):
    manifest, cli = case
    groups = evaluate(manifest).group_table()
    rows = cli["groups"]["rows"]
    assert rows and len(groups) == len(rows) and groups.attrs["over"] == cli["groups"]["over"]
    assert list(groups.columns) == list(rows[0])
    assert str(groups["n"].dtype) == "int64" and all(str(groups[k].dtype) == "float64" for k in METRICS)
    for i, row in enumerate(rows):
        got = groups.iloc[i]
        bad = [k for k in groups.columns if not _same(k, got[k], row[k])]
        assert not bad, (i, {k: (got[k], row[k]) for k in bad})


def test_the_group_means_are_the_means_of_the_table_rows(case):
    # an independent reading of the same numbers: pandas' own group means over the rows the groups average
    manifest, _ = case
    result = evaluate(manifest)
    table, groups = result.table(), result.group_table()
    rows = table[table["split"] == "test"] if groups.attrs["over"] == "test" else table
    # a group row is one group, method, calibration and estimate (the aided filter's forward and smoothed apart)
    keys = ["group", "method", "calibration", "estimate"]
    rows, groups = rows.fillna({"estimate": "-"}), groups.fillna({"estimate": "-"})
    means = rows.groupby(keys, sort=False)[list(METRICS)].mean()
    counts = rows.groupby(keys, sort=False).size()
    mine = groups.set_index(keys)
    assert list(mine.index) == list(means.index)
    np.testing.assert_array_equal(mine["n"].to_numpy(), counts.loc[mine.index].to_numpy())
    np.testing.assert_allclose(mine[list(METRICS)].to_numpy(), means.loc[mine.index].to_numpy(), rtol=1e-12,
                               atol=1e-12)


def test_evaluate_takes_a_manifest_path_or_a_dataset_and_nothing_else(tmp_path):
    ds = write_foreign_dataset(tmp_path / "data", LAYOUTS["truth-ned"], seed=1)
    by_path = evaluate(str(ds.manifest)).to_json()
    by_dataset = evaluate(load_dataset(ds.manifest), workers=2).to_json()
    one = evaluate(load_dataset(ds.manifest), workers=1).to_json()     # the default takes every core
    assert json.dumps(by_path, sort_keys=True) == json.dumps(by_dataset, sort_keys=True) \
        == json.dumps(one, sort_keys=True)
    with pytest.raises(ParameterError, match="dataset: dict, expected a Dataset or the path of a manifest"):
        evaluate({"recordings": []})
    with pytest.raises(ParameterError, match="course_m"):
        evaluate(ds.manifest, course_m=-1.0)
