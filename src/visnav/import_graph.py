"""The package's module import graph, from the source (``ast``, nothing imported), and its cycles.

    python -c "import visnav.import_graph as g; g.main()"

prints the module-level and the deferred (inside a function or under ``if TYPE_CHECKING``) imports
between visnav modules and every cycle, and exits 1 if there is one. A cycle is searched on the
module-level imports and, separately, on all imports together (a deferred import still makes two
modules depend on each other); tests/test_import_rules.py asserts both are acyclic. A name imported
through ``importlib`` (the "module:attr" registries ``app/missions.SIMULATION``,
``analysis/run_metrics.METRICS``) is not an edge: those registries name plug-ins, they do not import them.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

PKG = Path(__file__).resolve().parent


def _module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _targets(node, current: str, is_pkg: bool, known: set[str]) -> list[str]:
    if isinstance(node, ast.Import):
        names = [a.name for a in node.names]
    else:
        base = node.module or ""
        if node.level:  # relative import
            pkg = current.split(".") if is_pkg else current.split(".")[:-1]
            pkg = pkg[: len(pkg) - (node.level - 1)]
            base = ".".join(pkg + ([base] if base else []))
        names = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base for a in node.names]
    out = []
    for n in names:
        while n and n not in known:  # visnav.x.y.attr -> the module visnav.x.y
            n = n.rpartition(".")[0]
        if n and n != current:
            out.append(n)
    return out


def import_graph(root: Path = PKG) -> tuple[dict[str, set[str]], dict[str, set[str]]]:
    """(module-level, deferred) imports: module -> the package's modules it imports."""
    files = {_module_name(p, root): p for p in sorted(root.rglob("*.py"))}
    known = set(files)
    top: dict[str, set[str]] = {m: set() for m in files}
    deferred: dict[str, set[str]] = {m: set() for m in files}

    def visit(node, m: str, is_pkg: bool, late: bool) -> None:
        for ch in ast.iter_child_nodes(node):
            if isinstance(ch, (ast.Import, ast.ImportFrom)):
                (deferred if late else top)[m].update(_targets(ch, m, is_pkg, known))
            elif isinstance(ch, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                visit(ch, m, is_pkg, True)
            elif isinstance(ch, ast.If) and "TYPE_CHECKING" in ast.unparse(ch.test):
                visit(ch, m, is_pkg, True)
            else:
                visit(ch, m, is_pkg, late)

    for m, p in files.items():
        visit(ast.parse(p.read_text(), str(p)), m, p.name == "__init__.py", False)
    for m in files:
        deferred[m] -= top[m]
    return top, deferred


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
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
        for w in sorted(graph.get(v, ())):
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

    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 10 * len(graph) + 100))
    try:
        for v in sorted(graph):
            if v not in index:
                strong(v)
    finally:
        sys.setrecursionlimit(limit)
    return sorted(out)


def main() -> None:
    top, deferred = import_graph()
    both = {m: top[m] | deferred[m] for m in top}
    n_top, n_def = sum(map(len, top.values())), sum(map(len, deferred.values()))
    bad = False
    for what, g in (("module-level imports", top), ("all imports (module-level + deferred)", both)):
        cyc = cycles(g)
        bad |= bool(cyc)
        print(f"{what}: {len(cyc)} cycle(s)" + "".join(f"\n  {' <-> '.join(c)}" for c in cyc))
    print(f"{len(top)} modules, {n_top} module-level and {n_def} deferred imports between them")
    raise SystemExit(1 if bad else 0)
