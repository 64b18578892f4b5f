"""The architecture, checked: every module lies in one layer and imports only its own layer and the
layers below it; the core never touches meshes."""

import ast
import pathlib

import pytest

PACKAGE = pathlib.Path(__file__).resolve().parent.parent / "skelfilter"

# Bottom to top; layers of one rank are siblings and may not import each other.
RANKS = {
    "errors": 0, "parameter_fields": 1, "presets": 1, "params": 1.5, "runtime": 2,
    "core": 3, "io": 3,
    "mesh": 4, "meshlab": 5,
    "evaluation": 6, "jobs": 6,
    "demo": 7, "cli": 8,
}
# What the core may import from outside skelfilter: arrays only.
CORE_LIBRARIES = {"numpy", "scipy", "numba", "math", "dataclasses", "contextlib", "functools"}


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        yield ".".join(parts), path


MODULES = dict(_modules())


def _imports(name, path):
    """The absolute names ``name`` imports."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            yield from (a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(anchor + ([node.module] if node.module else []))
            yield base
            # ``from skelfilter.mesh import pipeline`` imports the module skelfilter.mesh.pipeline.
            yield from (f"{base}.{a.name}" for a in node.names if f"{base}.{a.name}" in MODULES)


def layer(name):
    return name.split(".")[1] if name.count(".") else None


def test_every_module_lies_in_a_known_layer():
    assert {layer(n) for n in MODULES} - {None} <= set(RANKS)


@pytest.mark.parametrize("name", [n for n in MODULES if layer(n)])
def test_imports_go_down_only(name):
    own = layer(name)
    for target in _imports(name, MODULES[name]):
        if not target.startswith("skelfilter"):
            continue
        assert target != "skelfilter", f"{name} imports the package's facade; import the module itself"
        other = layer(target)
        assert other == own or RANKS[other] < RANKS[own], f"{name} ({own}) imports {target} ({other})"


@pytest.mark.parametrize("name", [n for n in MODULES if layer(n) == "core"])
def test_the_core_is_arrays_only(name):
    outside = {t.split(".")[0] for t in _imports(name, MODULES[name]) if t and not t.startswith("skelfilter")}
    assert outside <= CORE_LIBRARIES, f"{name} imports {sorted(outside - CORE_LIBRARIES)}"


def test_the_rule_catches_an_upward_import(tmp_path):
    """The check itself can fail: a core module importing the mesh layer is caught."""
    bad = tmp_path / "bad.py"
    bad.write_text("from skelfilter.mesh import voxelize\nfrom ..io import mesh_files\n")
    found = set(_imports("skelfilter.core.bad", bad))
    assert "skelfilter.mesh.voxelize" in found and "skelfilter.io.mesh_files" in found
    assert RANKS[layer("skelfilter.mesh.voxelize")] > RANKS["core"]


def test_no_module_over_450_lines():
    long = {n: len(p.read_text().splitlines()) for n, p in MODULES.items()}
    assert {n: k for n, k in long.items() if k > 450} == {}


ROOT = PACKAGE.parent
# The product, the benchmark harness and the experiments: every module of the tree that imports others.
TREE = {".".join(p.relative_to(ROOT).with_suffix("").parts[:-1] if p.name == "__init__.py"
                 else p.relative_to(ROOT).with_suffix("").parts): p
        for folder in ("skelfilter", "benchmarks", "experiments") for p in sorted((ROOT / folder).rglob("*.py"))}


def _tree_imports(name, path):
    """The modules of `TREE` that ``name`` imports (anywhere in it, functions included), by their names."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(anchor + ([node.module] if node.module else []))
            # ``from package import module`` imports the module; ``from module import name``, the module
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in TREE else base for a in node.names]
        else:
            continue
        yield from (t for t in targets if t in TREE and t != name)


def _cycles(graph):
    """The strongly connected components of more than one module (Tarjan's algorithm)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    return found


def _graph():
    return {name: set(_tree_imports(name, path)) for name, path in TREE.items()}


def test_the_import_graph_has_no_circle():
    assert _cycles(_graph()) == []


def test_the_circle_check_can_fail():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_the_harness_and_the_product_import_no_experiment():
    for name, targets in _graph().items():
        if not name.startswith("experiments"):
            assert not {t for t in targets if t.startswith("experiments")}, f"{name} imports an experiment"
        if name.startswith("skelfilter"):
            assert not {t for t in targets if t.startswith("benchmarks")}, f"{name} imports the benchmark harness"


@pytest.mark.parametrize("path", sorted((ROOT / "tests").glob("*.py")), ids=lambda p: p.name)
def test_the_products_tests_import_no_experiment(path):
    imported = {t for node in ast.walk(ast.parse(path.read_text()))
                for t in ([a.name for a in node.names] if isinstance(node, ast.Import)
                          else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])}
    assert not {t for t in imported if t == "experiments" or t.startswith("experiments.")}


def test_the_route_and_the_decision_each_have_one_home():
    # the decision: which balls and voxels stay; every module of it in core.decision, none elsewhere
    decision = {"pruning_rules", "selection", "stage_pruning", "noise_estimate", "feature_restore", "two_sided",
                "noise_handles"}
    assert {n.rsplit(".", 1)[1] for n in MODULES if n.startswith("skelfilter.core.decision.")} == decision
    assert not {n for n in MODULES if n.rsplit(".", 1)[-1] in decision and ".decision." not in n}
    # the mesh's route: decided in mesh.route alone, which the mesh pipeline and nothing below reads
    readers = {n for n, p in MODULES.items() if "skelfilter.mesh.route" in set(_imports(n, p))}
    assert readers <= {"skelfilter.mesh.pipeline"}, readers
