#!/usr/bin/env python3
"""Size, complexity and structure of the package.

Sizes: modules over 400 lines, classes over 250 lines and functions of cyclomatic complexity over
12 (radon). Structure (of the package directory, ``dynamixel_handler`` by default):

- lineage: the in-package classes in a class's lineage (the class and every ancestor defined in
  the package, base names resolved through the modules' imports and re-exports; classes of the
  standard library or other packages do not count) -- at most ``LINEAGE_CLASSES`` of them, and
  the sum of their lines (``class`` statement to last line) at most ``LINEAGE_LINES``;
- family-name comparisons: string comparisons against a servo family name (``FAMILY_NAMES``)
  outside ``control_table/``. One is counted per comparison expression (``ast.Compare``) in which
  an ``==``, ``!=``, ``in`` or ``not in`` has a family name as a string constant on either side,
  directly or as an element of a tuple/list/set literal; and per ``match`` case whose pattern is a
  family-name string. At most ``FAMILY_COMPARISONS``;
- import circles: strongly connected sets of modules in the static import graph, which holds
  every ``import`` / ``from ... import`` of a module wherever it stands (module level, functions,
  ``if TYPE_CHECKING:``, ``try``). ``from P import n`` is an edge to ``P.n`` when that is a module,
  else to ``P``; parent packages imported only implicitly are no edge. None allowed.

- forwards in the fronts: methods and properties of a front class (``FRONTS``) whose body, past a
  docstring, is one statement handing the call on: ``[return] self.<part>.<name>(<its own
  arguments>)`` or ``return self.<part>.<name>``, the part reached one or two levels deep
  (``self.<a>.<b>.<name>`` counts too). At most the number ``FRONTS`` gives each;
- runtime registrations: a part that puts itself into another's table at run time: a call of
  ``<x>.register(...)`` (``atexit`` aside) or ``<h>.attach(self)`` (``h``, ``handler``, ``intake``). Routes are fixed by who builds
  the parts (``Intake.attach`` called by the assembler with the part it built). None allowed;
- protocol branches: a comparison of a protocol number (a name or attribute ``protocol`` or
  ``version``) with the constant 1 or 2, outside the family objects and framers
  (``PROTOCOL_EXEMPT``). At most ``PROTOCOL_BRANCHES`` (a ceiling that only goes down);
- parameter-name lookups: a string constant naming a parameter of ``config.SCHEMA`` (a literal
  name, or one starting with the fixed part of a name built by an f-string) used as a subscript
  or as the first argument of a ``get``/``get_parameter`` call, outside ``PARAM_EXEMPT``. At most
  ``PARAM_LOOKUPS``.

Prints one line per offender and a summary of every figure; ``--check`` exits 1 when a size
offender remains, ``--check --structure`` also when a structure rule is broken.

    python scripts/metrics.py [--check [--structure]] [PATH ...]   (default: dynamixel_handler)
"""
from __future__ import annotations

import argparse
import ast
import sys
from dataclasses import dataclass, field
from pathlib import Path

from radon.complexity import cc_visit
from radon.visitors import Class

MODULE_LINES, CLASS_LINES, FUNCTION_CC = 400, 250, 12
LINEAGE_CLASSES, LINEAGE_LINES, FAMILY_COMPARISONS = 3, 400, 2
FAMILY_NAMES = frozenset({"X", "P", "PRO", "Pro"})
FAMILY_EXEMPT = "control_table"
#: front classes (module relative to the package, class) -> the most one-line forwards allowed
FRONTS = {("core.handler", "Handler"): 9, ("bus.core", "DynamixelBus"): 10}
#: the modules that may look parameters up by name (and the set-up tool, a command line without
#: node parameters, whose dictionaries share some key names), and how many lookups the others may
#: make: none, every other part is given typed settings (``Settings``, the tool's ``UnifySettings``)
PARAM_EXEMPT = ("config", "config_checks", "ros.params", "setup_tool")
PARAM_LOOKUPS = 0
#: where a protocol number may be compared: the family objects and tables, the framers
PROTOCOL_EXEMPT = ("control_table", "protocol")
PROTOCOL_BRANCHES = 0


def _offenders(path: Path) -> tuple[list[str], int, int, int]:
    text = path.read_text()
    lines = text.count("\n")
    found: list[str] = []
    modules = classes = functions = 0
    seen: set[int] = set()
    if lines > MODULE_LINES:
        found.append(f"{path}: module {lines} lines")
        modules += 1
    for block in cc_visit(text):
        if isinstance(block, Class):
            size = block.endline - block.lineno + 1
            if size > CLASS_LINES:
                found.append(f"{path}:{block.lineno}: class {block.name} {size} lines")
                classes += 1
            members = block.methods
        else:
            members = [block]
        for fn in members:
            for f in [fn, *getattr(fn, "closures", [])]:
                if f.lineno in seen:  # radon lists a method in its class and again on its own
                    continue
                seen.add(f.lineno)
                if f.complexity > FUNCTION_CC:
                    found.append(f"{path}:{f.lineno}: {f.fullname} complexity {f.complexity}")
                    functions += 1
    return found, modules, classes, functions


# ---------------------------------------------------------------------------- structure
@dataclass
class Module:
    name: str                   # dotted: pkg.sub.mod (a package's __init__ is pkg.sub)
    path: Path
    tree: ast.Module
    is_package: bool
    #: name bound at module level -> ("module", dotted) or ("name", module, name) or ("class", module, name)
    names: dict[str, tuple[str, ...]] = field(default_factory=dict)


def load_package(root: Path) -> dict[str, Module]:
    """Every module under the package directory ``root``, by dotted name."""
    out: dict[str, Module] = {}
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        is_package = parts[-1] == "__init__"
        if is_package:
            parts = parts[:-1]
        name = ".".join(parts)
        out[name] = Module(name, path, ast.parse(path.read_text(), str(path)), is_package)
    for mod in out.values():
        _bind_names(mod, out)
    return out


def _absolute(mod: Module, node: ast.ImportFrom) -> str:
    """The module a ``from ... import`` names, made absolute."""
    if not node.level:
        return node.module or ""
    base = mod.name.split(".")
    base = base if mod.is_package else base[:-1]
    base = base[:len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _bind_names(mod: Module, modules: dict[str, Module]) -> None:
    for node in mod.tree.body:
        if isinstance(node, ast.ClassDef):
            mod.names[node.name] = ("class", mod.name, node.name)
        elif isinstance(node, ast.ImportFrom):
            src = _absolute(mod, node)
            for alias in node.names:
                full = f"{src}.{alias.name}"
                mod.names[alias.asname or alias.name] = ("module", full) if full in modules else ("name", src, alias.name)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.asname:
                    mod.names[alias.asname] = ("module", alias.name)


def _resolve(modules: dict[str, Module], binding: tuple[str, ...], depth: int = 0) -> tuple[str, str] | None:
    """The in-package class (module, name) a binding ends at, following re-exports; None if none."""
    if depth > 20:
        return None
    if binding[0] == "class":
        return binding[1], binding[2]
    if binding[0] == "name" and binding[1] in modules:
        nxt = modules[binding[1]].names.get(binding[2])
        return None if nxt is None else _resolve(modules, nxt, depth + 1)
    return None


def _base_binding(mod: Module, base: ast.expr) -> tuple[str, ...] | None:
    if isinstance(base, ast.Name):
        return mod.names.get(base.id)
    if isinstance(base, ast.Attribute) and isinstance(base.value, ast.Name):
        owner = mod.names.get(base.value.id)
        if owner is not None and owner[0] == "module":
            return ("name", owner[1], base.attr)
    return None


def lineages(modules: dict[str, Module]) -> dict[str, tuple[list[str], int]]:
    """Every in-package class (``module.Class``) -> the in-package classes of its lineage (itself
    first) and the sum of their lines."""
    classes: dict[tuple[str, str], ast.ClassDef] = {}
    bases: dict[tuple[str, str], list[tuple[str, str]]] = {}
    for mod in modules.values():
        for node in mod.tree.body:
            if isinstance(node, ast.ClassDef):
                key = (mod.name, node.name)
                classes[key] = node
                found = (_base_binding(mod, b) for b in node.bases)
                bases[key] = [r for r in (_resolve(modules, b) for b in found if b is not None) if r is not None]
    out: dict[str, tuple[list[str], int]] = {}
    for key, node in classes.items():
        seen: list[tuple[str, str]] = []
        todo = [key]
        while todo:
            k = todo.pop(0)
            if k in seen or k not in classes:
                continue
            seen.append(k)
            todo += bases.get(k, [])
        lines = sum((classes[k].end_lineno or classes[k].lineno) - classes[k].lineno + 1 for k in seen)
        out[f"{key[0]}.{key[1]}"] = ([f"{m}.{c}" for m, c in seen], lines)
    return out


def _is_family(node: ast.expr) -> bool:
    if isinstance(node, ast.Constant):
        return isinstance(node.value, str) and node.value in FAMILY_NAMES
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return any(_is_family(e) for e in node.elts)
    return False


def family_comparisons(tree: ast.AST) -> list[int]:
    """Line numbers of the comparisons against a family name in ``tree`` (see the module doc)."""
    lines = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            if any(isinstance(op, (ast.Eq, ast.NotEq, ast.In, ast.NotIn)) and (_is_family(sides[k]) or _is_family(sides[k + 1]))
                   for k, op in enumerate(node.ops)):
                lines.append(node.lineno)
        elif isinstance(node, ast.match_case):
            if any(isinstance(p, ast.MatchValue) and _is_family(p.value) for p in ast.walk(node.pattern)):
                lines.append(node.pattern.lineno)
    return lines


def import_graph(modules: dict[str, Module]) -> dict[str, set[str]]:
    """Module -> the in-package modules it imports anywhere in its text (see the module doc)."""
    graph: dict[str, set[str]] = {name: set() for name in modules}
    for mod in modules.values():
        for node in ast.walk(mod.tree):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                src = _absolute(mod, node)
                targets = [f"{src}.{a.name}" if f"{src}.{a.name}" in modules else src for a in node.names]
            graph[mod.name].update(t for t in targets if t in modules and t != mod.name)
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected sets of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            scc = []
            while True:
                w = stack.pop()
                on.discard(w)
                scc.append(w)
                if w == v:
                    break
            if len(scc) > 1:
                out.append(sorted(scc))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10 * len(graph) + 100))
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(out)


def structure(root: Path) -> tuple[list[str], dict[str, int]]:
    """Offender lines and figures of the structure rules for the package directory ``root``."""
    modules = load_package(root)
    found: list[str] = []
    lines_of = lineages(modules)
    worst_n = max((len(c) for c, _ in lines_of.values()), default=0)
    worst_lines = max((n for _, n in lines_of.values()), default=0)
    bad_lineages = 0
    for name, (chain, n) in sorted(lines_of.items()):
        if len(chain) > LINEAGE_CLASSES or n > LINEAGE_LINES:
            found.append(f"{name}: lineage of {len(chain)} in-package classes, {n} lines ({' <- '.join(chain)})")
            bad_lineages += 1
    family = 0
    for mod in modules.values():
        if FAMILY_EXEMPT in mod.name.split("."):
            continue
        for line in family_comparisons(mod.tree):
            found.append(f"{mod.path}:{line}: family-name comparison")
            family += 1
    rings = circles(import_graph(modules))
    found += [f"import circle: {' <-> '.join(r)}" for r in rings]
    package = root.name
    fronts = forwards(modules, package)
    over = 0
    for (module, cls), most in FRONTS.items():
        count = fronts.get(f"{module}.{cls}", 0)
        if count > most:
            found.append(f"{module}.{cls}: {count} one-line forwards (at most {most})")
            over += 1
    names, starts = param_names(modules.get(f"{package}.config"))
    lookups = 0
    for mod in modules.values():
        inner = mod.name.split(".", 1)[-1]
        if any(inner == e or inner.startswith(e + ".") for e in PARAM_EXEMPT):
            continue
        for line in param_lookups(mod.tree, names, starts):
            found.append(f"{mod.path}:{line}: parameter looked up by name")
            lookups += 1
    registrations = 0
    branches = 0
    for mod in modules.values():
        for line in runtime_registrations(mod.tree):
            found.append(f"{mod.path}:{line}: a part registers itself at run time")
            registrations += 1
        if any(e in mod.name.split(".")[1:2] for e in PROTOCOL_EXEMPT):
            continue
        for line in protocol_branches(mod.tree):
            found.append(f"{mod.path}:{line}: protocol branch")
            branches += 1
    return found, {"lineages": bad_lineages, "longest_lineage": worst_n, "largest_lineage_lines": worst_lines,
                   "family_comparisons": family, "import_circles": len(rings), "forwards_over": over,
                   "forwards": sum(fronts.values()), "param_lookups": lookups,
                   "registrations": registrations, "protocol_branches": branches,
                   **{f"forwards {k}": v for k, v in fronts.items()}}


def structure_broken(figures: dict[str, int]) -> bool:
    return bool(figures["lineages"] or figures["family_comparisons"] > FAMILY_COMPARISONS
                or figures["import_circles"] or figures["forwards_over"]
                or figures["param_lookups"] > PARAM_LOOKUPS or figures["registrations"]
                or figures["protocol_branches"] > PROTOCOL_BRANCHES)


def _self_chain(node: ast.expr) -> bool:
    """``self.<part>.<name>`` or ``self.<a>.<b>.<name>``: a part's member one or two levels deep."""
    if not (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Attribute)):
        return False
    owner = node.value.value
    if isinstance(owner, ast.Attribute):
        owner = owner.value
    return isinstance(owner, ast.Name) and owner.id == "self"


def runtime_registrations(tree: ast.AST) -> list[int]:
    """Lines of ``<x>.register(...)`` (not ``atexit.register``) and ``<x>.attach(self)``."""
    found = []
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)):
            continue
        owner = node.func.value
        if node.func.attr == "register" and not (isinstance(owner, ast.Name) and owner.id == "atexit"):
            found.append(node.lineno)
        elif node.func.attr == "attach" and _intake_owner(owner) and \
                any(isinstance(a, ast.Name) and a.id == "self" for a in node.args):
            found.append(node.lineno)
    return found


def _intake_owner(node: ast.expr) -> bool:
    """``h``, ``handler``, ``intake`` or an attribute of that name: what takes a part's requests."""
    name = node.attr if isinstance(node, ast.Attribute) else node.id if isinstance(node, ast.Name) else ""
    return name in ("h", "handler", "intake")


def _protocol_number(node: ast.expr) -> bool:
    name = node.attr if isinstance(node, ast.Attribute) else node.id if isinstance(node, ast.Name) else ""
    return name in ("protocol", "version")


def _one_or_two(node: ast.expr) -> bool:
    if isinstance(node, ast.Constant):
        return type(node.value) is int and node.value in (1, 2)
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return bool(node.elts) and all(_one_or_two(e) for e in node.elts)
    return False


def protocol_branches(tree: ast.AST) -> list[int]:
    """Lines of the comparisons of a protocol number with 1 or 2 (see the module doc)."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            if any((_protocol_number(sides[k]) and _one_or_two(sides[k + 1]))
                   or (_one_or_two(sides[k]) and _protocol_number(sides[k + 1])) for k in range(len(node.ops))):
                found.append(node.lineno)
    return found


def is_forward(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    """One statement that hands the call on to a part, with the method's own arguments unchanged."""
    body = fn.body
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
            and isinstance(body[0].value.value, str):
        body = body[1:]
    if len(body) != 1 or not isinstance(body[0], (ast.Return, ast.Expr)) or body[0].value is None:
        return False
    value = body[0].value
    if isinstance(value, ast.Attribute):
        return isinstance(body[0], ast.Return) and _self_chain(value)
    if not isinstance(value, ast.Call) or not _self_chain(value.func):
        return False
    own = {a.arg for a in fn.args.args[1:] + fn.args.kwonlyargs}
    passed = list(value.args) + [k.value for k in value.keywords]
    return all(isinstance(a, ast.Name) and a.id in own for a in passed)


def forwards(modules: dict[str, Module], package: str) -> dict[str, int]:
    """Front class -> its one-line forwards."""
    out: dict[str, int] = {}
    for (module, cls), _ in FRONTS.items():
        mod = modules.get(f"{package}.{module}")
        if mod is None:
            continue
        for node in mod.tree.body:
            if isinstance(node, ast.ClassDef) and node.name == cls:
                out[f"{module}.{cls}"] = sum(1 for f in node.body if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef))
                                             and is_forward(f))
    return out


def param_names(config: Module | None) -> tuple[set[str], tuple[str, ...]]:
    """The parameter names of ``SCHEMA`` written out in config.py, and the fixed starts of those
    built by f-strings."""
    names: set[str] = set()
    starts: list[str] = []
    for node in ast.walk(config.tree) if config is not None else ():
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "_p" and node.args):
            continue
        first = node.args[0]
        if isinstance(first, ast.Constant) and isinstance(first.value, str):
            names.add(first.value)
        elif isinstance(first, ast.JoinedStr) and first.values and isinstance(first.values[0], ast.Constant):
            starts.append(str(first.values[0].value))
    return names, tuple(s for s in starts if s)


def param_lookups(tree: ast.AST, names: set[str], starts: tuple[str, ...]) -> list[int]:
    """Lines where a parameter is looked up by name: ``x["name"]``, ``x.get("name")``."""
    def named(node: ast.expr) -> bool:
        if isinstance(node, ast.JoinedStr) and node.values and isinstance(node.values[0], ast.Constant):
            node = node.values[0]
            return isinstance(node.value, str) and bool(node.value) and str(node.value).startswith(starts)
        return isinstance(node, ast.Constant) and isinstance(node.value, str) and (
            node.value in names or (bool(starts) and node.value.startswith(starts)))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Subscript) and named(node.slice):
            found.append(node.lineno)
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and \
                node.func.attr in ("get", "get_parameter") and node.args and named(node.args[0]):
            found.append(node.lineno)
    return found


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 when an offender remains")
    ap.add_argument("--structure", action="store_true",
                    help="with --check: the lineage, family-comparison and import-circle rules fail it too")
    ap.add_argument("paths", nargs="*", default=["dynamixel_handler"])
    args = ap.parse_args(argv)
    totals = [0, 0, 0]
    for root in map(Path, args.paths):
        for path in sorted(root.rglob("*.py") if root.is_dir() else [root]):
            found, *counts = _offenders(path)
            for line in found:
                print(line)
            totals = [a + b for a, b in zip(totals, counts)]
    print(f"modules > {MODULE_LINES} lines: {totals[0]}; classes > {CLASS_LINES} lines: {totals[1]}; "
          f"functions with complexity > {FUNCTION_CC}: {totals[2]}")
    broken = False
    for root in map(Path, args.paths):
        if not (root / "__init__.py").is_file():
            continue
        found, fig = structure(root)
        for line in found:
            print(line)
        print(f"{root}: lineages over {LINEAGE_CLASSES} classes or {LINEAGE_LINES} lines: {fig['lineages']} "
              f"(longest {fig['longest_lineage']} classes, largest {fig['largest_lineage_lines']} lines); "
              f"family-name comparisons outside {FAMILY_EXEMPT}/: {fig['family_comparisons']} "
              f"(at most {FAMILY_COMPARISONS}); import circles: {fig['import_circles']}")
        fronts = ", ".join(f"{k[len('forwards '):]} {v}" for k, v in fig.items() if k.startswith("forwards "))
        print(f"{root}: one-line forwards in the fronts: {fronts or 'none'}; parameter-name lookups outside "
              f"{', '.join(PARAM_EXEMPT)}: {fig['param_lookups']} (at most {PARAM_LOOKUPS})")
        print(f"{root}: runtime registrations: {fig['registrations']} (at most 0); protocol branches outside "
              f"{', '.join(PROTOCOL_EXEMPT)}: {fig['protocol_branches']} (at most {PROTOCOL_BRANCHES})")
        broken = broken or structure_broken(fig)
    return 1 if args.check and (any(totals) or (args.structure and broken)) else 0


if __name__ == "__main__":
    sys.exit(main())
