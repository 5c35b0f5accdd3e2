"""The package's module import graph, from the source (``ast``, nothing imported), and its cycles.

    python -c "import visnav.import_graph as g; g.main()"
    python -m visnav.import_graph --layers     # the package layer diagram of docs/architecture.md

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


def package_edges(root: Path = PKG) -> dict[str, set[str]]:
    """package -> the other packages of visnav it imports (module-level or deferred); a top-level module
    (``cli``, ``measurements``, ...) counts as a package of its own."""
    top, deferred = import_graph(root)
    edges: dict[str, set[str]] = {}
    for m in top:
        pkg = m.split(".")[1] if "." in m else m
        edges.setdefault(pkg, set())
        for t in top[m] | deferred[m]:
            tgt = t.split(".")[1] if "." in t else t
            if tgt != pkg:
                edges[pkg].add(tgt)
    return edges


def layers(edges: dict[str, set[str]]) -> dict[str, int]:
    """Each package's layer: 0 for one that imports no other package, else one above the highest it imports
    (the longest import path down from it). Needs an acyclic package graph."""
    out: dict[str, int] = {}

    def depth(p: str, seen: tuple[str, ...] = ()) -> int:
        if p in seen:
            raise ValueError(f"packages import each other: {' -> '.join(seen + (p,))}")
        if p not in out:
            out[p] = 1 + max((depth(q, seen + (p,)) for q in edges.get(p, ())), default=-1)
        return out[p]

    for p in sorted(edges):
        depth(p)
    return out


def layer_diagram(root: Path = PKG) -> str:
    """The package layers as a Mermaid flowchart, generated from the imports: one row per layer (top: the
    command line), an arrow for each import that is not implied by a longer path (transitive reduction)."""
    edges = package_edges(root)
    if "visnav" in edges:  # the package's own __init__ is not a layer
        edges.pop("visnav")
    for v in edges.values():
        v.discard("visnav")
    level = layers(edges)

    def reach(p: str) -> set[str]:
        seen, todo = set(), list(edges[p])
        while todo:
            q = todo.pop()
            if q not in seen:
                seen.add(q)
                todo.extend(edges.get(q, ()))
        return seen

    below = {p: reach(p) for p in edges}
    lines = ["```mermaid", "flowchart TD"]
    for lv in sorted(set(level.values()), reverse=True):
        members = sorted(p for p in level if level[p] == lv)
        lines.append(f"  subgraph L{lv}[\"layer {lv}\"]")
        lines.extend(f"    {p}" for p in members)
        lines.append("  end")
    for p in sorted(edges):
        for q in sorted(edges[p]):
            if not any(q in below[r] for r in edges[p] if r != q):  # not implied through another import
                lines.append(f"  {p} --> {q}")
    lines.append("```")
    return "\n".join(lines)


def main() -> None:
    if "--layers" in sys.argv[1:]:
        print(layer_diagram())
        return
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


if __name__ == "__main__":  # pragma: no cover
    main()
