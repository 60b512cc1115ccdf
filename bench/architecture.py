"""Architecture figures of a racc tree (issue 24): how the code is laid out and wired.

Prints, for the tree given (default: the one this script sits in):
- lines per package under ``rac/`` (every line of every ``.py`` file);
- internal imports (``rac.*``): at module level and inside functions, and how many of the
  function-level ones dodge a cycle (the module graph without that one arrow has a path back);
- the import cycles between modules (strongly connected components of the module graph,
  function-level imports counted, ``if TYPE_CHECKING:`` imports not);
- the 15 largest functions by lines;
- commands that import other commands.

    python bench/architecture.py [ROOT]

Reads source only (``ast``), imports nothing from the tree.
"""

from __future__ import annotations

import ast
import sys
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import networkx as nx


@dataclass(frozen=True, slots=True)
class Import:
    source: str
    target: str
    line: int
    in_function: bool


def module_name(root: Path, path: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def resolve(modules: set[str], name: str) -> str | None:
    """The longest known module a dotted name lies in (``rac.a.b.f`` → ``rac.a.b``)."""
    while name:
        if name in modules:
            return name
        name = name.rpartition(".")[0]
    return None


def command_modules(root: Path) -> set[str]:
    """The module of each ``racc`` command (rac/cli.py's COMMANDS; ``import`` is
    ``import_model``), not the helpers beside them in rac/commands/."""
    tree = ast.parse((root / "rac" / "cli.py").read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign) and any(
            isinstance(t, ast.Name) and t.id == "COMMANDS" for t in node.targets
        ):
            names = ast.literal_eval(node.value)
            return {"rac.commands." + n.replace("-", "_") for n in names}
    return set()


def top_package(module: str) -> str:
    return ".".join(module.split(".")[:2])


def is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def imports_of(module: str, is_package: bool, tree: ast.Module, modules: set[str]) -> list[Import]:
    found: list[Import] = []
    package = module if is_package else module.rpartition(".")[0]

    def visit(node: ast.AST, in_function: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and is_type_checking(child):
                continue
            inside = in_function or isinstance(
                child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda
            )
            targets: list[str] = []
            if isinstance(child, ast.Import):
                targets = [alias.name for alias in child.names]
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:
                    anchor = package.split(".")
                    anchor = anchor[: len(anchor) - (child.level - 1)]
                    base = ".".join([*anchor, base] if base else anchor)
                # `from rac.x import y`: y may be a module or a name in rac.x.
                targets = [f"{base}.{alias.name}" for alias in child.names]
            for name in targets:
                if not name.startswith("rac"):
                    continue
                target = resolve(modules, name)
                if target is not None and target != module:
                    found.append(Import(module, target, child.lineno, in_function))
            visit(child, inside)

    visit(tree, False)
    return found


def function_sizes(module: str, tree: ast.Module) -> list[tuple[int, str]]:
    sizes: list[tuple[int, str]] = []

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                name = f"{prefix}.{child.name}"
                if not isinstance(child, ast.ClassDef):
                    end = child.end_lineno or child.lineno
                    sizes.append((end - child.lineno + 1, f"{name}:{child.lineno}"))
                visit(child, name)

    visit(tree, module)
    return sizes


def main(argv: list[str]) -> int:
    root = Path(argv[1]) if len(argv) > 1 else Path(__file__).resolve().parent.parent
    files = sorted((root / "rac").rglob("*.py"))
    trees = {module_name(root, f): (f, ast.parse(f.read_text(), str(f))) for f in files}
    modules = set(trees)

    print(f"# Architecture of {root}")
    print("\n## Lines per package under rac/")
    lines: Counter[str] = Counter()
    for module, (path, _tree) in trees.items():
        package = module if path.name == "__init__.py" else module.rpartition(".")[0]
        top = ".".join(package.split(".")[:2])
        lines[top] += len(path.read_text().splitlines())
    for package, count in sorted(lines.items(), key=lambda kv: (-kv[1], kv[0])):
        print(f"{count:7d}  {package}")
    print(f"{sum(lines.values()):7d}  total in {len(files)} files")

    imports: list[Import] = []
    for module, (path, tree) in trees.items():
        imports += imports_of(module, path.name == "__init__.py", tree, modules)
    imports = list(dict.fromkeys(imports))  # `from rac.x import a, b`: one import of rac.x
    graph: nx.DiGraph = nx.DiGraph()
    graph.add_nodes_from(modules)
    for imp in imports:
        graph.add_edge(imp.source, imp.target)
    module_level = {(i.source, i.target) for i in imports if not i.in_function}

    print("\n## Internal imports")
    in_function = [i for i in imports if i.in_function]
    dodging = []
    for imp in in_function:
        if (imp.source, imp.target) in module_level:
            continue
        # Dodges a cycle: at module level this arrow would close a loop back to its source.
        if nx.has_path(graph, imp.target, imp.source):
            dodging.append(imp)
    package_graph: nx.DiGraph = nx.DiGraph()
    for imp in imports:
        package_graph.add_edge(top_package(imp.source), top_package(imp.target))
    dodging_packages = [
        imp
        for imp in in_function
        if imp not in dodging
        and top_package(imp.source) != top_package(imp.target)
        and nx.has_path(package_graph, top_package(imp.target), top_package(imp.source))
    ]
    print(f"{len(imports)} internal imports, {len(in_function)} inside functions,")
    print(f"{len(dodging)} of which would close a cycle between modules at module level:")
    for imp in sorted(dodging, key=lambda i: (i.source, i.line)):
        print(f"  {imp.source}:{imp.line} -> {imp.target}")
    print(f"and {len(dodging_packages)} more close a cycle between packages:")
    for imp in sorted(dodging_packages, key=lambda i: (i.source, i.line)):
        print(f"  {imp.source}:{imp.line} -> {imp.target}")

    print("\n## Import cycles between modules (function-level imports counted)")
    cycles = [sorted(c) for c in nx.strongly_connected_components(graph) if len(c) > 1]
    for component in sorted(cycles, key=lambda c: (-len(c), c)):
        print(f"  {len(component)} modules: {', '.join(component)}")
    print(
        f"{len(cycles)} cycles (strongly connected components), "
        f"{sum(len(c) for c in cycles)} modules in them"
    )

    print("\n## Import cycles between packages (rac.X; top-level modules count as packages)")
    packages: nx.DiGraph = nx.DiGraph()
    for imp in imports:
        source, target = top_package(imp.source), top_package(imp.target)
        if source != target:
            packages.add_edge(source, target)
    package_cycles = [sorted(c) for c in nx.strongly_connected_components(packages) if len(c) > 1]
    for component in sorted(package_cycles, key=lambda c: (-len(c), c)):
        print(f"  {len(component)} packages: {', '.join(component)}")
    print(f"{len(package_cycles)} cycles between packages")

    print("\n## The 15 largest functions")
    sizes = [s for module, (_p, tree) in trees.items() for s in function_sizes(module, tree)]
    for size, name in sorted(sizes, key=lambda s: (-s[0], s[1]))[:15]:
        print(f"{size:5d}  {name}")

    print("\n## Commands importing commands")
    commands = command_modules(root)
    pairs = sorted(
        {(i.source, i.target) for i in imports if i.source in commands and i.target in commands}
    )
    for source, target in pairs:
        print(f"  {source} -> {target}")
    print(f"{len(pairs)} imports between the {len(commands)} command modules of rac/cli.py")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv))
