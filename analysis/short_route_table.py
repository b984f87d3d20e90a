"""The paper's short-route table (MoRPI-A/G x RD/GC on the 6.3 m indoor route) from the library.

Gains and the step rule come from the train runs; errors are the test runs' mean end-point error
in % of the travelled distance, beside the paper's value.

Usage: ``python3 analysis/short_route_table.py [DATA_ROOT]`` (default: $MORPI_DATA).
"""
import sys

from morpi_filters import MorpiError, dataset, evaluate
from morpi_filters.report.common import fmt, md_table

try:
    root = dataset.resolve_data_root(sys.argv[1] if len(sys.argv) > 1 else None)
except MorpiError as exc:
    sys.exit(f"short_route_table: {exc}")
result = evaluate.evaluate_tables(root, alternatives=False)
rows = []
for c in result.cells:
    if c.spec.table == "short_route":
        rows.append([c.spec.phone, f"{c.spec.p2p_m:g} m", c.spec.method, c.spec.calibration,
                     fmt(c.spec.paper_percent), fmt(c.ours_percent), fmt(c.distance_percent), fmt(c.gain, 4)])
print(md_table(["phone", "p2p", "method", "cal", "paper %", "ours %", "distance error %", "gain"], rows))
