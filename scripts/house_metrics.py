"""Measure the house rules of the package code: import cycles, imports inside functions,
function lengths and dated lines.

``python scripts/house_metrics.py`` prints the figures; ``--list imports|cycles|long|dates``
lists the places behind one of them. The same functions back ``tests/test_house.py`` and
``tests/test_floors.py``.
"""

from __future__ import annotations

import argparse
import ast
import re
import statistics
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("sim2real", "sysid", "robots", "randomizers")
DATE = re.compile(r"20\d\d-\d\d-\d\d")


@dataclass(frozen=True, kw_only=True)
class LocalImport:
    """An import statement inside a function body."""

    module: str
    line: int
    target: str


def modules(root: Path = ROOT) -> dict[str, Path]:
    """Dotted module name -> file, for every module of the four packages."""
    found: dict[str, Path] = {}
    for package in PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join(parts)] = path
    return found


def _resolve(module: str, is_package: bool, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    base = module.split(".")
    if not is_package:
        base = base[:-1]
    base = base[: len(base) - (node.level - 1)] if node.level > 1 else base
    return ".".join([*base, *([node.module] if node.module else [])])


def _targets(module: str, path: Path, node: ast.AST, known: dict[str, Path]) -> list[str]:
    """The project modules an import statement loads (the longest known prefix of each)."""
    names: list[str] = []
    if isinstance(node, ast.Import):
        names = [alias.name for alias in node.names]
    elif isinstance(node, ast.ImportFrom):
        base = _resolve(module, path.name == "__init__.py", node)
        names = [f"{base}.{alias.name}" for alias in node.names] + [base]
    out: list[str] = []
    for name in names:
        parts = name.split(".")
        while parts and ".".join(parts) not in known:
            parts.pop()
        if parts:
            out.append(".".join(parts))
    return sorted(set(out))


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def import_graph(root: Path = ROOT) -> tuple[dict[str, set[str]], list[LocalImport]]:
    """Module import edges (top level and inside functions; not under ``TYPE_CHECKING``)
    and the list of imports written inside functions."""
    known = modules(root)
    edges: dict[str, set[str]] = {name: set() for name in known}
    local: list[LocalImport] = []
    for module, path in known.items():
        tree = ast.parse(path.read_text(), filename=str(path))

        def visit(
            node: ast.AST, in_function: bool, module: str = module, path: Path = path
        ) -> None:
            for child in ast.iter_child_nodes(node):
                if isinstance(child, ast.If) and _is_type_checking(child):
                    continue
                inner = in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef))
                if isinstance(child, (ast.Import, ast.ImportFrom)):
                    if isinstance(child, ast.ImportFrom) and child.module == "__future__":
                        continue
                    for target in _targets(module, path, child, known):
                        if target != module and not module.startswith(target + "."):
                            edges[module].add(target)
                    if in_function:
                        first = child.names[0].name
                        what = child.module if isinstance(child, ast.ImportFrom) else first
                        local.append(
                            LocalImport(module=module, line=child.lineno, target=str(what or "."))
                        )
                visit(child, inner)

        visit(tree, False)
    return edges, local


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def strong(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    import sys

    sys.setrecursionlimit(10000)
    for v in sorted(edges):
        if v not in index:
            strong(v)
    return out


def package_edges(edges: dict[str, set[str]]) -> dict[str, set[str]]:
    """Edges between packages and subpackages (a module counts for its own package)."""
    known = set(modules())
    pkg_of = {}
    for m in edges:
        path = modules()[m]
        pkg_of[m] = m if path.name == "__init__.py" else m.rpartition(".")[0] or m
    out: dict[str, set[str]] = {}
    for m, targets in edges.items():
        for t in targets:
            a, b = pkg_of[m], pkg_of[t]
            if a != b and not a.startswith(b + ".") and not b.startswith(a + "."):
                out.setdefault(a, set()).add(b)
    del known
    return out


def function_lengths(root: Path = ROOT) -> list[tuple[int, str]]:
    """(body lines, 'module:function') of every function, docstrings not counted."""
    out: list[tuple[int, str]] = []
    for module, path in modules(root).items():
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                body = node.body
                if (
                    body
                    and isinstance(body[0], ast.Expr)
                    and isinstance(body[0].value, ast.Constant)
                    and isinstance(body[0].value.value, str)
                    and len(body) > 1
                ):
                    body = body[1:]
                start = body[0].lineno
                end = max(getattr(n, "end_lineno", start) or start for n in body)
                out.append((end - start + 1, f"{module}:{node.name}"))
    return out


def dated_lines(root: Path = ROOT) -> list[str]:
    """'file:line' of every line with a date in the package code."""
    out = []
    for package in PACKAGES:
        for path in sorted((root / package).rglob("*")):
            if path.suffix in {".py", ".yaml"}:
                for i, line in enumerate(path.read_text().splitlines(), 1):
                    if DATE.search(line):
                        out.append(f"{path.relative_to(root)}:{i}")
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--list", choices=["imports", "cycles", "long", "dates"])
    args = parser.parse_args()
    edges, local = import_graph()
    module_cycles = cycles(edges)
    pkg_cycles = cycles(package_edges(edges))
    lengths = sorted(function_lengths())
    sizes = [n for n, _ in lengths]
    dates = dated_lines()
    if args.list == "imports":
        for item in local:
            print(f"{item.module}:{item.line} {item.target}")
    elif args.list == "cycles":
        for c in module_cycles + pkg_cycles:
            print(" <-> ".join(c))
    elif args.list == "long":
        for n, name in lengths[::-1][:60]:
            print(n, name)
    elif args.list == "dates":
        print("\n".join(dates))
    p90 = statistics.quantiles(sizes, n=10)[-1]
    print(
        f"modules {len(edges)}; module cycles {len(module_cycles)}; package cycles "
        f"{len(pkg_cycles)}; imports inside functions {len(local)}; functions {len(sizes)}: "
        f"median {statistics.median(sizes):.0f}, p90 {p90:.0f}, max {sizes[-1]} lines; "
        f"dated lines {len(dates)}"
    )


if __name__ == "__main__":
    main()
