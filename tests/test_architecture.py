"""The house keeps its shape: import direction between subsystems, no private cross-imports, a
light ``import twin``, modules of readable size."""

import ast
import subprocess
import sys

import pytest

from conftest import ROOT

# twin's subsystems, lowest first: a module may import only from its own layer or the ones below
# (docs/architecture.md draws the same picture).
LAYERS = [
    {"twin", "twin.errors", "twin.io", "twin.text", "twin.html", "twin.plugins", "twin.arrays", "twin.results",
     "twin.processes"},
    {"twin.parts", "twin.firmware"},
    {"twin.effects"},
    {"twin.model"},
    {"twin.measurement"},
    {"twin.estimation"},  # fitting a twin to data: the problem, the fit, noise models, linear algebra
    {"twin.diagnosis", "twin.datasets"},  # screening, selection, audit; seeded cases with a known truth
    {"twin.discovery"},
    {"twin.finding"},  # the typed compare result and its wording
    {"twin.reporting"},
    {"twin.compensation", "twin.calibration"},
    {"twin.studies", "twin.fleet", "twin.plan"},  # studies, fleets and test plans run the diagnosis many times
    {"twin.workflows"},
    {"twin.cli"},
]
RANK = {name: i for i, layer in enumerate(LAYERS) for name in layer}
SOURCES = [p for d in ("twin", "sim", "fitting", "tests", "benchmarks") for p in (ROOT / d).rglob("*.py")]


def _imports(path, runtime_only: bool = False):
    """(module imported, names imported) for every import in ``path``, nested ones included;
    ``runtime_only``: without those under ``if TYPE_CHECKING:`` (annotations only)."""
    tree = ast.parse(path.read_text())
    if runtime_only:
        for node in ast.walk(tree):
            if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
                node.body = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from ((a.name, []) for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            yield node.module, [a.name for a in node.names]


def _subsystem(module: str) -> str:
    """``twin.diagnosis.screen`` → ``twin.diagnosis``; ``twin.errors`` → ``twin.errors``."""
    parts = module.split(".")
    return ".".join(parts[:2]) if len(parts) > 1 else parts[0]


def _module_name(path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    return ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)


@pytest.mark.parametrize("package,forbidden", [("sim", {"twin", "fitting"}), ("fitting", {"twin", "sim"})])
def test_sim_and_fitting_import_nothing_from_the_other_packages(package, forbidden):
    files = list((ROOT / package).rglob("*.py"))
    assert files
    for f in files:
        bad = {m.split(".")[0] for m, _ in _imports(f)} & forbidden
        assert not bad, f"{f.relative_to(ROOT)} imports {bad}"


def test_every_twin_subsystem_has_a_layer():
    found = {_subsystem(_module_name(p)) for p in (ROOT / "twin").rglob("*.py")}
    assert found <= set(RANK), f"subsystems without a layer in LAYERS: {sorted(found - set(RANK))}"


def test_twin_subsystems_import_only_downwards():
    """Acyclic by construction: every import goes to the same layer or a lower one, and within a
    layer no two subsystems import each other."""
    edges = set()
    for path in (ROOT / "twin").rglob("*.py"):
        src = _subsystem(_module_name(path))
        for module, _ in _imports(path):
            if module.split(".")[0] != "twin":
                continue
            dst = _subsystem(module)
            assert RANK[dst] <= RANK[src], f"{path.relative_to(ROOT)} ({src}) imports {module} from a higher layer"
            if dst != src:
                edges.add((src, dst))
    mutual = {(a, b) for a, b in edges if (b, a) in edges}
    assert not mutual, f"subsystems importing each other: {sorted(mutual)}"


def test_no_module_imports_a_private_name_from_another():
    offenders = []
    for path in SOURCES:
        for module, names in _imports(path):
            if module.split(".")[0] in ("twin", "sim", "fitting") and any(
                    n.startswith("_") and not n.startswith("__") for n in names):
                offenders.append(f"{path.relative_to(ROOT)}: from {module} import {', '.join(names)}")
    assert not offenders, "\n".join(offenders)


def test_library_modules_stay_readable():
    """No module in twin/, sim/, fitting/ over 450 lines (a subsystem grows by files, not by length)."""
    long = {str(p.relative_to(ROOT)): n for d in ("twin", "sim", "fitting") for p in (ROOT / d).rglob("*.py")
            if (n := len(p.read_text().splitlines())) > 450}
    assert not long, long


def test_import_twin_does_not_load_heavy_packages():
    code = ("import sys, twin, twin.cli, twin.model.scenario, twin.model.simulate, twin.model.dataset; "
            "print(sorted(m for m in ('torch', 'pyvista', 'matplotlib', 'vtk') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def _module_graph(package_dir) -> dict[str, set[str]]:
    """Module → the modules of the same package it imports (lazy imports inside functions included;
    ``from package import module`` is an edge to that module, not to the package's ``__init__``)."""
    modules = {_module_name(p): p for p in package_dir.glob("*.py")}
    graph = {}
    for name, path in modules.items():
        graph[name] = set()
        for module, names in _imports(path, runtime_only=True):
            subs = [t for t in (f"{module}.{n}" for n in names) if t in modules]
            for target in subs or [module]:
                if target in modules and target != name:
                    graph[name].add(target)
    return graph


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of ``graph`` (a list of modules, the first repeated last), or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node):
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return None


@pytest.mark.parametrize("package", sorted({p.parent for d in ("twin", "sim", "fitting") for p in (ROOT / d).rglob("*.py")}),
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_no_import_cycle_between_the_files_of_a_package(package):
    """A lazy import inside a function hides a cycle from Python, not from this test."""
    cycle = _cycle(_module_graph(package))
    assert cycle is None, " → ".join(cycle)


def test_the_cycle_finder_finds_a_cycle():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None


def _loose_types(tp, where: str, seen: set) -> list[str]:
    """Annotations in ``tp`` (walked into dataclass fields) that say nothing of their contents:
    a bare ``dict``/``list``/``tuple``, ``Any``, ``object``, or a dict whose values are one of those."""
    import dataclasses
    import typing

    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if tp in (dict, list, tuple, set, object, typing.Any) or (origin in (dict, list, tuple) and not args):
        return [f"{where}: {getattr(tp, '__name__', tp)}"]
    if dataclasses.is_dataclass(tp):
        if tp in seen:
            return []
        seen.add(tp)
        hints = typing.get_type_hints(tp)
        return [bad for f in dataclasses.fields(tp) for bad in _loose_types(hints[f.name], f"{tp.__name__}.{f.name}", seen)]
    return [bad for a in args if a is not Ellipsis for bad in _loose_types(a, where, seen)]


def test_result_types_hold_no_untyped_dict_or_object():
    """Every field of every result type (walked from each command's result) says what it holds."""
    from twin.workflows.schemas import result_types

    loose = [bad for name, tp in result_types().items() for bad in _loose_types(tp, name, set())]
    assert not loose, loose
    assert _loose_types(dict[str, dict], "probe", set()) == ["probe: dict"]  # the walk sees nested dicts


#: what a renderer never calls: loading a scenario, a log or a plugin, or fitting, diagnosing, solving
WORKFLOW_MODULES = ("twin.model.scenario", "twin.model.simulate", "twin.model.package", "twin.measurement",
                    "twin.estimation.fit", "twin.diagnosis.diagnose", "twin.diagnosis.compare", "twin.finding.build",
                    "twin.calibration.workflow", "twin.workflows", "sim.fem")


def test_reporting_only_renders():
    """``twin/reporting`` draws and writes what a workflow computed; it runs no workflow itself
    (a type named for annotations only, under ``TYPE_CHECKING``, runs nothing)."""
    offenders = []
    for path in (ROOT / "twin" / "reporting").rglob("*.py"):
        for module, names in _imports(path, runtime_only=True):
            if any(module == w or module.startswith(w + ".") for w in WORKFLOW_MODULES) or \
                    (module == "twin.effects" and "load_plugin" in names):
                offenders.append(f"{path.relative_to(ROOT)}: {module}")
    assert not offenders, offenders
