"""The house rules of ARCHITECTURE.md, checked on the source: the import graph and one room per piece of maths.

Every module of the package is parsed with ``ast`` (imports inside functions
included); nothing is imported, so the checks see what the code says, not what
one run happens to load.
"""
from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "morpi_filters"

#: The flow of ARCHITECTURE.md as layers, lowest first. A module may import
#: modules of its own layer or of lower layers, never of a higher one. Every
#: module of ``report/`` is in the pages layer.
LAYERS = (
    ("foundation", {"errors", "deprecation", "units", "choice", "resources", "results", "outputs", "parallel", "_jit"}),
    ("inputs", {"params", "dataset", "manifest", "fetch"}),
    ("calibration", {"calibration", "_calibration_loops"}),
    ("navigation", {"strapdown", "_strapdown_loops", "steps", "symbolic", "error_model", "eskf", "aided",
                    "_aided_kernel"}),
    ("synthetic recordings", {"simulate", "synthetic", "foreign"}),
    ("field", {"field"}),
    ("evaluation", {"evaluate"}),
    ("studies", {"field_aided", "dataset_eval", "curves", "montecarlo", "assessment"}),
    ("pages", {"report"}),
    ("command", {"cli"}),
)


def _name(path: Path) -> str:
    rel = path.relative_to(PKG).with_suffix("")
    parts = [p for p in rel.parts if p != "__init__"]
    return ".".join(parts) or "__init__"


def _modules() -> dict:
    """Module name (relative to the package, ``report.tables``) -> parsed tree."""
    return {_name(f): ast.parse(f.read_text(), filename=str(f)) for f in sorted(PKG.rglob("*.py"))}


def _imports(name: str, tree: ast.AST):
    """(internal modules, external top-level packages) imported anywhere in the module."""
    package = name.split(".")[:-1] if name != "__init__" else []
    if (PKG / Path(*name.split("."))).is_dir():  # a package's __init__
        package = name.split(".")
    inside, outside = set(), set()
    known = set(_modules_cache())
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level == 0:
                top = node.module.split(".")[0]
                if top == "morpi_filters":
                    mod = node.module.split(".")[1:]
                    for a in node.names:
                        full = ".".join(mod + [a.name])
                        inside.add(full if full in known else (".".join(mod) or "__init__"))
                else:
                    outside.add(top)
                continue
            base = package[: len(package) - (node.level - 1)]
            mod = base + (node.module.split(".") if node.module else [])
            for a in node.names:  # "from X import y": y is a module of X, or a name defined in X
                full = ".".join(mod + [a.name])
                inside.add(full if full in known else (".".join(mod) or "__init__"))
        elif isinstance(node, ast.Import):
            for a in node.names:
                top = a.name.split(".")[0]
                if top == "morpi_filters":
                    inside.add(".".join(a.name.split(".")[1:]) or "__init__")
                else:
                    outside.add(top)
    inside.discard(name)
    return {m if m else "__init__" for m in inside}, outside


_CACHE = {}


def _modules_cache():
    if not _CACHE:
        _CACHE.update(_modules())
    return _CACHE


def _graph():
    return {name: _imports(name, tree) for name, tree in _modules_cache().items()}


def _layer(name: str) -> int:
    if name == "__init__":
        return 0
    top = name.split(".")[0]
    for i, (_, members) in enumerate(LAYERS):
        if top in members:
            return i
    raise AssertionError(f"module {name} is in no layer: add it to LAYERS in tests/test_architecture.py "
                         "and to the rooms of ARCHITECTURE.md")


def test_every_module_has_a_layer_and_every_import_resolves():
    mods = _modules_cache()
    for name, (inside, _) in _graph().items():
        _layer(name)
        for m in inside:
            assert m in mods, f"{name} imports {m}, which is not a module of the package"


def test_nothing_imports_upward():
    upward = [f"{name} ({LAYERS[_layer(name)][0]}) imports {m} ({LAYERS[_layer(m)][0]})"
              for name, (inside, _) in _graph().items() for m in sorted(inside)
              if m != "__init__" and _layer(m) > _layer(name)]
    assert upward == []


def test_no_import_cycles():
    graph = {name: {m for m in inside if m != "__init__"} for name, (inside, _) in _graph().items()}
    state, cycles = {}, []

    def visit(node, stack):
        state[node] = "open"
        stack.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == "open":
                cycles.append(stack[stack.index(nxt):] + [nxt])
            elif nxt not in state:
                visit(nxt, stack)
        stack.pop()
        state[node] = "done"

    for node in sorted(graph):
        if node not in state:
            visit(node, [])
    assert cycles == []


def test_the_graph_reader_sees_an_upward_import_and_a_cycle():
    # the checks above can fail: an evaluate -> report import is upward, and two modules importing each other cycle
    tree = ast.parse("def f():\n    from ..report import tables\n")
    inside, _ = _imports("evaluate.compare", tree)
    assert inside == {"report.tables"} and _layer("report.tables") > _layer("evaluate.compare")
    tree = ast.parse("from ..evaluate import TablesStudy\nfrom . import plots\n")
    inside, _ = _imports("report.tables", tree)
    assert inside == {"evaluate", "report.plots"}


def test_only_report_plots_imports_matplotlib_and_only_symbolic_imports_sympy():
    graph = _graph()
    assert {n for n, (_, ext) in graph.items() if "matplotlib" in ext} == {"report.plots"}
    assert {n for n, (_, ext) in graph.items() if "sympy" in ext} == {"symbolic"}


def _loaded_by_every_module(name: str) -> bool:
    """Whether importing every module of the package, in a fresh interpreter, loads the package `name`."""
    names = ["morpi_filters." + n for n in _modules_cache() if n != "__init__"]
    code = ("import importlib, sys\n"
            f"for n in {names!r}:\n    importlib.import_module(n)\n"
            f"print({name!r} in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=PKG.parent, check=True)
    return out.stdout.strip() == "True"


def test_importing_the_package_loads_no_matplotlib_and_selects_no_backend():
    # every module imported in a fresh interpreter: none of them may load matplotlib (the figures
    # are drawn on demand) nor call matplotlib.use
    assert not _loaded_by_every_module("matplotlib")
    for name, tree in _modules_cache().items():
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "use":
                assert not (isinstance(node.func.value, ast.Name) and node.func.value.id == "matplotlib"), name


def test_only_the_loader_and_the_dataset_tables_import_pandas_and_importing_the_package_does_not():
    # pandas (the loader's C tokenizer) costs about half a second to import: it is imported inside the
    # loader, when a file is read, and inside the dataset evaluation's DataFrame tables, when one is
    # asked for, so commands that read no recording never pay for it
    graph = _graph()
    assert {n for n, (_, ext) in graph.items() if "pandas" in ext} == {"dataset.fastcsv", "dataset_eval.results"}
    assert not _loaded_by_every_module("pandas")
    for name in ("dataset.fastcsv", "dataset_eval.results"):
        tree = _modules_cache()[name]
        top = {a.name.split(".")[0] for node in tree.body if isinstance(node, (ast.Import, ast.ImportFrom))
               for a in node.names if isinstance(node, ast.Import)}
        assert "pandas" not in top, name


def test_only_the_jit_accessor_imports_numba_and_importing_the_package_does_not():
    # numba (the compiler of every loops module: the 3D Monte Carlo kernel, the aided filter's forward pass,
    # the strapdown's, rest detection's, the steps' and the rule search's loops) costs about 0.6 s to import
    # and load its cached machine code: it is imported by _jit on a kernel's first call, so only commands that
    # run one pay for it
    graph = _graph()
    assert {n for n, (_, ext) in graph.items() if "numba" in ext} == {"_jit"}
    assert not _loaded_by_every_module("numba")


def _loops_modules() -> list:
    """The modules holding compiled loops: those that make their accessor with ``_jit.loops``."""
    return sorted({name for name, tree in _modules_cache().items() for node in ast.walk(tree)
                   if isinstance(node, ast.Call) and ast.unparse(node.func) == "loops"})


def test_every_loops_module_is_private_to_its_concept():
    # each concept keeps its loops beside it, in a private module that only its own room imports, and the loops
    # that call its loops (the aided kernel and the steps' loops call the strapdown's and calibration's); the
    # aided study's tuning reads the aided kernel's names of the measurement kinds
    mods = _loops_modules()
    assert {"_calibration_loops", "_strapdown_loops", "_aided_kernel", "steps._loops", "field._loops",
            "montecarlo._batch_ins"} <= set(mods)
    owners = {"_calibration_loops": {"calibration", "steps._loops"}, "_strapdown_loops": {"strapdown", "_aided_kernel"},
              "_aided_kernel": {"aided", "field_aided.tuning"}}
    for name, (inside, _) in _graph().items():
        for m in inside & set(mods):
            room = m.split(".")[0] if "." in m else None
            assert name.split(".")[0] == room or name in owners.get(m, ()), f"{name} imports the loops of {m}"


_ONE_COMPILATION = """
import importlib
import sys
from pathlib import Path
from morpi_filters import cli, synthetic
tmp = Path(sys.argv[1])
root = synthetic.write_dataset(tmp / "ds", seed=2, runs_per_folder=1)
for command in ("tables", "aided"):
    cli.main([command, "--data", str(root), "--out", str(tmp / command)])
for module in sys.argv[2:]:
    for name, f in importlib.import_module("morpi_filters." + module).compiled().items():
        print(module + "." + name, len(f.signatures))
"""


_SWING = """
import numpy as np
from morpi_filters.steps import _loops
t = np.arange(9.0)
psi = np.radians([0.0, 9.0, 1.0, 4.0, 2.0, 9.0, 3.0, 8.0, 4.0])     # swings 9, 3, 7, 5 deg: median 6, unsorted 5
print(_loops.compiled()["swing_median"](t, psi, np.array([0.0, 2.0, 4.0, 6.0, 8.0])))
"""


def test_editing_a_callee_loop_recompiles_its_callers(tmp_path):
    # numba's disk cache checks only the file a function is defined in; the steps' swing median calls
    # calibration's sort (another file): with the sort made a no-op in a copy of the package, the
    # cached swing median must not keep the old sort's machine code
    import os
    import shutil

    shutil.copytree(PKG, tmp_path / "morpi_filters", ignore=shutil.ignore_patterns("__pycache__"))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"), PYTHONPATH=str(tmp_path))

    def swing():
        r = subprocess.run([sys.executable, "-c", _SWING], capture_output=True, text=True, cwd=tmp_path, env=env,
                           timeout=600)
        assert r.returncode == 0, r.stderr[-2000:]
        return float(r.stdout.split()[-1])

    sorted_median = swing()
    assert sorted_median == pytest.approx(6.0)
    assert swing() == sorted_median                                     # from the cache, the same
    path = tmp_path / "morpi_filters" / "_calibration_loops.py"
    text = path.read_text()
    head = "def sort_head(a, n):\n"
    doc_end = text.index('"""', text.index('"""', text.index(head)) + 3) + 3
    path.write_text(text[:doc_end] + "\n    return" + text[doc_end:])  # the sort leaves the values as they are
    assert swing() == pytest.approx(5.0)


def test_each_compiled_loop_compiles_once_for_the_commands(tmp_path):
    # numba compiles a loop once per argument type (a read-only array is another type than a writeable
    # one, and a literal integer another than an integer): each compilation costs up to seconds on a
    # fresh install, so the callers hand their inputs read-only (_jit.read_only) and no loop of any loops module
    # is reached with two types by `morpi tables` and `morpi aided` on a synthetic dataset. The run starts
    # with an empty cache, as a fresh install does: numba then compiles (and counts) the loops called only
    # from inside another one too.
    env = dict(__import__("os").environ, MPLBACKEND="Agg", NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    r = subprocess.run([sys.executable, "-c", _ONE_COMPILATION, str(tmp_path), *_loops_modules()],
                       capture_output=True, text=True, cwd=PKG.parent, env=env, timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    counts = dict(line.rsplit(" ", 1) for line in r.stdout.splitlines() if line.count(" ") >= 1
                  and line.rsplit(" ", 1)[1].isdigit())
    assert counts and {name: int(n) for name, n in counts.items() if int(n) > 1} == {}
    # both commands reached them, and a loop of each module they run on this dataset (one run per folder: no
    # leave-one-out errors)
    for name in ("_aided_kernel.forward_member", "steps._loops.turn_values", "_calibration_loops.moving_stats",
                 "_strapdown_loops.rodrigues"):
        assert int(counts[name]) == 1, name


#: Markdown a page is made of: a heading at the start of a line, a table row or separator, an
#: image or a link target, a block quote at the start of the text.
MARKDOWN = re.compile(r"(^|\n)#{1,6} |(^|\n)\|.*\||\|---|!\[|\]\(|^> ")


def _strings(tree: ast.AST):
    """(line, text) of the string literals of a module, docstrings left out.

    An f-string is one text, each replacement field written ``{}``.
    """
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                skip.add(id(body[0].value))
        elif isinstance(node, ast.JoinedStr):
            skip.update(id(v) for v in node.values)
            yield node.lineno, "".join(v.value if isinstance(v, ast.Constant) else "{}" for v in node.values)
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip:
            yield node.lineno, node.value


#: Text outside ``report/`` that the rule lets through, each with its reason: the comment lines
#: of the committed checksum file (``sha256sum`` format, not markdown), written by fetch; the
#: README.md of a synthetic dataset, a file of the dataset beside its CSVs and manifest (as the
#: field dataset has its own), not a report page.
NOT_MARKDOWN = {("fetch", "# SHA-256 of each recording"), ("fetch", "# relative to that folder"),
                ("fetch", "# morpi_filters.fetch.write_checksums"), ("synthetic", "# Synthetic MoRPI dataset\n"),
                # the same-result rule reads the numbers of a page, it writes none
                ("results", "(?<![\\w.])[-+]?")}


def test_no_module_outside_report_writes_markdown():
    found = [f"{name}:{line}: {text[:60]!r}" for name, tree in _modules_cache().items()
             if name.split(".")[0] != "report" for line, text in _strings(tree) if MARKDOWN.search(text)
             and not any(name == m and text.startswith(start) for m, start in NOT_MARKDOWN)]
    assert found == []


def test_the_markdown_rule_finds_the_pieces_of_a_page():
    page = ast.parse('x = "## Title"\ny = f"| {a} | b |"\nz = "![fig](fig.png)"\nw = "> **Synthetic data.**"\n'
                     'v = "|---|---|"\n')
    assert sum(bool(MARKDOWN.search(t)) for _, t in _strings(page)) == 5
    prose = ast.parse('x = "--times: 3 s must be >= 0 (see # of runs)"\ny = "a|b"\n')
    assert not any(MARKDOWN.search(t) for _, t in _strings(prose))


# ----------------------------------------------------------------------------- one room per piece of maths

def _source() -> dict:
    return {_name(f): f.read_text() for f in sorted(PKG.rglob("*.py"))}


def _where(pattern: str) -> list:
    """(module, line) of every match of `pattern` in the package's code (comments left out)."""
    rx = re.compile(pattern)
    hits = []
    for name, text in _source().items():
        for i, line in enumerate(text.splitlines(), 1):
            code = line.split("#", 1)[0] if not line.lstrip().startswith(("'", '"')) else line
            if rx.search(code):
                hits.append((name, i))
    return hits


def _functions_calling(attr_chain: str) -> set:
    """Qualified names of the functions whose body calls ``attr_chain`` (e.g. ``hashlib.sha256``)."""
    out = set()
    for name, tree in _modules_cache().items():
        for fn in ast.walk(tree):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for node in ast.walk(fn):
                if isinstance(node, ast.Call) and ast.unparse(node.func) == attr_chain:
                    out.add(f"{name}.{fn.name}")
    return out


@pytest.mark.parametrize("concept, pattern, home", [
    ("the Weinberg length (a fourth root)", r"def weinberg_length\b|\*\*\s*\(?\s*(0\.25|1\s*/\s*4)\b|sqrt\(\s*np\.sqrt",
     {"steps.reckon"}),
    ("the rate integrator", r"def integrate_rate\b", {"strapdown"}),
    ("the gravity constant", r"\b9\.80665\b", {"units"}),
    ("the gravity model (WGS84 normal gravity)", r"def normal_gravity\b|\b9\.78032", {"calibration"}),
    ("the rotation-vector conversion (Rodrigues)", r"def rotvec_to_C\b|1(\.0)?\s*-\s*np\.cos\(", {"strapdown"}),
    ("the atomic writer", r"def atomic_path\b", {"outputs.atomic"}),
    ("the file checksum", r"def sha256_file\b|def _sha256_stream\b", {"fetch"}),
])
def test_one_definition(concept, pattern, home):
    hits = _where(pattern)
    assert {m for m, _ in hits} == home, f"{concept}: found at {hits}, expected only in {home}"


def test_one_definition_counts():
    # exactly one line each: a second copy inside the same module is a duplicate too
    assert len(_where(r"def weinberg_length\b")) == 1
    assert len(_where(r"\*\*\s*\(?\s*(0\.25|1\s*/\s*4)\b")) == 1        # the fourth root of weinberg_length
    assert len(_where(r"def integrate_rate\b")) == 1
    assert len(_where(r"\b9\.80665\b")) == 1
    assert len(_where(r"def rotvec_to_C\b")) == 1
    assert len(_where(r"1(\.0)?\s*-\s*np\.cos\(")) == 1                  # the (1 - cos t)/t^2 term of Rodrigues
    assert len(_where(r"def atomic_path\b")) == 1
    assert len(_where(r"def sha256_file\b")) == 1


def test_the_heading_wrapper_uses_the_rate_integrator():
    # steps.integrate_heading is MoRPI's name for the heading; it must delegate, not integrate on its own
    tree = _modules_cache()["steps.prepare"]
    fn = next(n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef) and n.name == "integrate_heading")
    calls = {ast.unparse(n.func) for n in ast.walk(fn) if isinstance(n, ast.Call)}
    assert "integrate_rate" in calls and not any("cumsum" in c or "trapz" in c or "trapezoid" in c for c in calls)


def test_files_are_renamed_into_place_only_by_the_atomic_writer_and_the_staged_swaps():
    renames = _functions_calling("os.replace") | _functions_calling("os.rename")
    assert renames == {"outputs.atomic.atomic_path", "outputs.claims.swap_in", "outputs.session.__exit__"}


def test_sha256_is_computed_by_the_checksum_and_the_monte_carlo_digest_only():
    # the file checksum (fetch) and the fingerprint of a study's per-run results (montecarlo.config.digest),
    # two different things; nothing else hashes
    assert _functions_calling("hashlib.sha256") == {"fetch._sha256_stream", "montecarlo.config.digest"}


def test_every_package_folder_is_shipped():
    """pyproject's explicit package list names every folder of the package that holds an ``__init__.py``,
    so a wheel carries every module the checkout has."""
    import tomllib

    listed = set(tomllib.loads((PKG.parent / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    folders = {".".join(("morpi_filters",) + p.parent.relative_to(PKG).parts) for p in PKG.rglob("__init__.py")}
    assert folders <= listed, sorted(folders - listed)


#: Private modules their concepts import by name: the compiled loops and the numba accessor.
_KERNEL_MODULES = {"_jit", "_calibration_loops", "_strapdown_loops", "_aided_kernel", "_loops", "_batch_ins"}


def _private_reads(tree: ast.AST) -> list:
    """(line, text) of every private name a module imports from another module of the package, or reads as an
    attribute of a module (or name) it imported from the package."""
    bound, out = set(), []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.level > 0 or (node.module or "").startswith("morpi_filters")):
            for a in node.names:
                if a.name.startswith("_") and not a.name.startswith("__") and a.name not in _KERNEL_MODULES:
                    out.append((node.lineno, f"from {'.' * node.level}{node.module or ''} import {a.name}"))
                bound.add(a.asname or a.name)
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("morpi_filters"):
                    bound.add(a.asname or a.name.split(".")[0])
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in bound
                and node.attr.startswith("_") and not node.attr.startswith("__")):
            out.append((node.lineno, f"{node.value.id}.{node.attr}"))
    return out


def test_no_module_reads_another_modules_private_names():
    found = [f"{name}:{line}: {text}" for name, tree in _modules_cache().items() for line, text in _private_reads(tree)]
    assert found == []


def test_the_private_name_rule_finds_a_private_import_and_a_private_attribute():
    tree = ast.parse("from .field import _loo_vector\nfrom . import field as fd\nx = fd._train_sets(d)\n"
                     "from . import _strapdown_loops\ny = _strapdown_loops.compiled()\n")
    assert [t for _, t in _private_reads(tree)] == ["from .field import _loo_vector", "fd._train_sets"]
