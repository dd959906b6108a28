#!/usr/bin/env python3
"""Finds loops of imports between the modules of each crate (issue 66: "no module imports a
module that imports it back, directly or around a loop").

    python3 tools/import_cycles.py                       # every crate of the repository
    python3 tools/import_cycles.py crates/monohand-media monohand-vision    # only these
    python3 tools/import_cycles.py --exclude crates/monohand                # all but these
    python3 tools/import_cycles.py --edges crates/monohand   # every import inside each loop
    python3 tools/import_cycles.py --layers crates/monohand=base,stages   # and no import up

Prints, for each crate, its loops: each strongly connected component of more than one
module, with the imports inside it (the first place each is written, and how many more).
With `--layers CRATE=BOTTOM,MIDDLE,...` (the crate's top-level modules, bottom first; every
other module is the top) it also prints each import from a layer to one above it, loop or
not. Exits 1 if there is a loop or such an import, 0 if none, 2 on a bad argument. Python 3 standard library only;
its tests: tools/test_import_cycles.py.

What is read (a crate is a folder with a Cargo.toml and a src/ under the repository; a
crate's Python packages are its python/*/ folders with an __init__.py):

Rust. A module is a file: src/lib.rs (else src/main.rs) is the crate's root, `crate`;
src/a/b.rs and src/a/b/mod.rs are `a::b`; src/a.rs beside a folder src/a/ is `a`, the
parent of what is in the folder. Inline modules (`mod x { ... }`) are part of their file:
`super::` inside them first climbs out of them. Comments and string literals are ignored.
The imports are:
  - `use` trees starting with `crate::`, `self::`, `super::`, a child module of the file
    (`pub use reader::VideoReader;` in video/mod.rs) or a name another `use` of the file
    bound to a module of the crate;
  - paths written anywhere in the code that start the same ways (`crate::a::f()`,
    `super::reader::ffmpeg_said(..)`, `reader::open(..)` after `mod reader;`), and
    `$crate::` in macros.
An import of `crate::a::b::Item` is an edge to the deepest module of the path that exists
(`a::b`, or `a` if there is no module `a::b`). If that module does not define `Item` but
only names it with a `use` of its own (a re-export, `pub use b::Item;`, or a private `use`
that a child reaches through `super::`), the edge goes on where that `use` leads, to the
module that defines `Item` (and there is no edge when it comes from another crate): the
module that re-exports an item is not what its importers depend on. A glob
(`use super::*`) is an edge to its module. A name that could not be found (a macro, say)
leaves the edge at the module the path names.

Test code is not read: inline modules under `#[cfg(test)]` (or `#[cfg(all(test, ..))]`),
files declared so (`#[cfg(test)] mod tests;`, with what is below them) and `#[cfg(test)]`
uses. A test may set a module up with the modules above it, as the crate's tests/ do.
`--tests` reads them too.

Parents and children. A module's imports of its own ancestors (its parent, the parent's
parent, ..., the crate's root) are no edges: a folder's front file (mod.rs, a.rs, lib.rs)
declares its parts, re-exports and dispatches to them, and the parts use what the front
defines for all of them (`use super::{Tile, NR};` in pointwise/avx2.rs), the way the
issue's models keep an operator apart from its kernels. So `pub use child::X;` in a parent
and the child's `use super::Shared;` are no loop. The front's imports of its parts do
count (parent -> child), like any other, so a loop that leaves the folder and comes back
is found: `conv -> int8` (the folder's front) `-> int8::ranges -> conv` is one. A parent
that only declares `mod child;` imports nothing. A module importing itself is no loop.
`--parents` counts a module's imports of its ancestors too (a child importing its parent,
which re-exports it, is then a loop of two).

Python. A module is a .py file (a .pyi stub stands for a compiled module that has no
.py); a package's __init__.py is the package. Imports are `import pkg.a`,
`from pkg.a import x` and the relative `from . import a`, `from .a import x`,
`from .. import b` of the package's own modules, anywhere in the file (inside functions
too: a deferred import still needs the other module). `from P import name` is an edge to
P.name when that is a module, else to P; `import a.b.c` to the deepest module that exists.
Imports of a module's own packages (`import monohand` in monohand/daft.py) are no edges,
as in Rust, unless `--parents`.
"""

from __future__ import annotations

import argparse
import ast
import os
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path

Module = tuple  # a module's path: () is the crate's root (or, in Python, the top package)


@dataclass
class Import:
    """One place a module imports another."""

    source: Module
    target: Module
    file: str  # relative to the crate folder
    line: int
    text: str


@dataclass
class Graph:
    """A crate's (or a Python package's) modules and imports."""

    name: str  # what is printed: the crate's folder, and the language
    modules: dict = field(default_factory=dict)  # Module -> file, relative to the crate
    imports: list = field(default_factory=list)  # [Import]
    label: callable = None  # Module -> printed name
    parents: bool = False  # whether a module's imports of its own ancestors count

    def counts(self, imp: Import) -> bool:
        """Whether an import is an edge of the graph: a module importing itself is not; nor,
        unless `parents`, one importing its own ancestor (its parent, the parent's parent,
        ..., the crate's root)."""
        a, b = imp.source, imp.target
        if a == b:
            return False
        return self.parents or a[: len(b)] != b

    def edges(self) -> dict:
        out: dict = {m: set() for m in self.modules}
        for imp in self.imports:
            if self.counts(imp):
                out[imp.source].add(imp.target)
        return out


# -- Rust ---------------------------------------------------------------------------------


def strip_rust(text: str) -> str:
    """The code without comments, string and char literals (each replaced by spaces, so
    that offsets and line numbers stay)."""
    out = list(text)
    n = len(text)
    i = 0

    def blank(a: int, b: int) -> None:
        for k in range(a, min(b, n)):
            if out[k] != "\n":
                out[k] = " "

    while i < n:
        c = text[i]
        if c == "/" and text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            blank(i, j)
            i = j
        elif c == "/" and text.startswith("/*", i):
            depth, j = 1, i + 2
            while j < n and depth:
                if text.startswith("/*", j):
                    depth, j = depth + 1, j + 2
                elif text.startswith("*/", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            blank(i, j)
            i = j
        elif c in "rb" and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.compile(r'(?:br|rb|r|b)?(#*)"').match(text, i)
            if m and ("r" in m.group(0) or m.group(1) == ""):
                if "r" in m.group(0):  # raw string: ends at a quote and as many #
                    end = text.find('"' + m.group(1), m.end())
                    j = n if end < 0 else end + 1 + len(m.group(1))
                else:
                    j = skip_string(text, m.end())
                blank(i, j)
                i = j
            elif text.startswith("b'", i):
                j = skip_char(text, i + 1)
                blank(i, j)
                i = j
            else:
                i += 1
        elif c == '"':
            j = skip_string(text, i + 1)
            blank(i, j)
            i = j
        elif c == "'":
            j = skip_char(text, i)
            if j > i + 1:
                blank(i, j)
            i = max(j, i + 1)
        else:
            i += 1
    return "".join(out)


def skip_string(text: str, i: int) -> int:
    """The index after the closing quote of a string whose body starts at i."""
    n = len(text)
    while i < n:
        if text[i] == "\\":
            i += 2
        elif text[i] == '"':
            return i + 1
        else:
            i += 1
    return n


def skip_char(text: str, i: int) -> int:
    """After a char literal starting with the quote at i; i + 1 if it is a lifetime."""
    if text.startswith("\\", i + 1):
        end = text.find("'", i + 3)
        return len(text) if end < 0 else end + 1
    if i + 2 < len(text) and text[i + 2] == "'":
        return i + 3
    return i + 1


IDENT = r"(?:r#)?[A-Za-z_][A-Za-z0-9_]*"
TOKEN = re.compile(
    r"(?P<mod>\bmod\s+(?P<modname>" + IDENT + r")\s*(?P<modend>[{;]))"
    r"|(?P<use>\buse\s+(?=[A-Za-z_:{$*]))"
    r"|(?P<open>\{)|(?P<close>\})"
    r"|(?P<path>(?<![\w:$])(?P<head>\$crate|" + IDENT + r")\s*::\s*(?=[A-Za-z_*{]))"
)
PATH_TAIL = re.compile(r"\s*::\s*(" + IDENT + r")")
DEFINITION = re.compile(
    r"\b(?:fn|struct|enum|trait|type|union|mod)\s+(" + IDENT + r")"
    r"|\bconst\s+(" + IDENT + r")\s*:"
    r"|\bstatic\s+(?:mut\s+)?(" + IDENT + r")\s*:"
    r"|\bmacro_rules!\s*(" + IDENT + r")"
)
USE_TOKEN = re.compile(r"\s*(::|\{|\}|,|\*|\bas\b|\$crate|" + IDENT + r")")


def parse_use_tree(text: str):
    """The paths of a use tree (without `use` and `;`): [(segments, alias, glob)]."""
    tokens = []
    pos = 0
    while True:
        m = USE_TOKEN.match(text, pos)
        if not m:
            break
        tokens.append(m.group(1))
        pos = m.end()
    out = []

    def tree(i: int, prefix: list) -> int:
        path = list(prefix)
        while i < len(tokens):
            t = tokens[i]
            if t == "::":
                i += 1
            elif t == "{":
                i += 1
                while i < len(tokens) and tokens[i] != "}":
                    if tokens[i] == ",":
                        i += 1
                        continue
                    i = tree(i, path)
                return i + 1
            elif t == "*":
                out.append((path, None, True))
                return i + 1
            elif t in (",", "}"):
                break
            elif t == "as":
                alias = tokens[i + 1] if i + 1 < len(tokens) else None
                out.append((path, alias, False))
                return i + 2
            else:
                path.append(t.removeprefix("r#"))
                i += 1
        if path and path != prefix:
            out.append((path, None, False))
        return i

    tree(0, [])
    # `a::{self, B}`: self names a itself
    return [(p[:-1] if p and p[-1] == "self" else p, a, g) for p, a, g in out]


@dataclass
class RustFile:
    module: Module
    rel: str
    uses: list = field(default_factory=list)  # [(segments, alias, glob, inline_depth, line, text)]
    paths: list = field(default_factory=list)  # [(segments, inline_depth, line, text)]
    definitions: set = field(default_factory=set)
    test_children: set = field(default_factory=set)  # `#[cfg(test)] mod x;`


def rust_modules(src: Path) -> dict:
    """Module -> path of its file, for the crate whose sources are in src."""
    root = src / "lib.rs" if (src / "lib.rs").exists() else src / "main.rs"
    modules = {}
    if not root.exists():
        return modules
    modules[()] = root
    for path in sorted(src.rglob("*.rs")):
        rel = path.relative_to(src)
        if path == root or rel.parts[0] == "bin":
            continue
        parts = list(rel.with_suffix("").parts)
        if parts[-1] == "mod":
            parts.pop()
        if len(parts) == 1 and parts[0] in ("lib", "main"):
            continue
        modules[tuple(parts)] = path
    return modules


ATTRIBUTES = re.compile(
    r"((?:#\s*\[(?:[^\[\]]|\[[^\[\]]*\])*\]\s*)+)(?:pub\s*(?:\([^)]*\))?\s*)?$"
)
CFG_TEST = re.compile(r"\bcfg\s*\((?:\s*all\s*\()?\s*test\b")


def test_only(code: str, start: int) -> bool:
    """Whether the item starting at `start` (its `mod` or `use`) has `#[cfg(test)]` (or
    `#[cfg(all(test, ...))]`) among the attributes right before it."""
    m = ATTRIBUTES.search(code[max(0, start - 400) : start])
    return bool(m and CFG_TEST.search(m.group(1)))


def scan_rust(path: Path, module: Module, rel: str, tests: bool) -> RustFile:
    """A file's imports; without `tests`, those of its `#[cfg(test)]` code are left out
    and its `#[cfg(test)] mod x;` children are noted in `test_children`."""
    raw = path.read_text(encoding="utf-8", errors="replace")
    code = strip_rust(raw)
    out = RustFile(module, rel)
    depth = 0
    inline = []  # each open inline module: (the brace depth its body starts at, test only)
    line_starts = [0] + [m.end() for m in re.finditer("\n", code)]

    def line_of(pos: int) -> int:
        lo, hi = 0, len(line_starts)
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if line_starts[mid] <= pos:
                lo = mid
            else:
                hi = mid
        return lo + 1

    def snippet(a: int, b: int) -> str:
        return " ".join(code[a:b].split())

    def skipped(start: int) -> bool:
        return not tests and (any(t for _, t in inline) or test_only(code, start))

    pos = 0
    while True:
        m = TOKEN.search(code, pos)
        if not m:
            break
        pos = m.end()
        if m.group("mod"):
            is_test = test_only(code, m.start())
            if m.group("modend") == "{":
                depth += 1
                inline.append((depth, is_test))
            elif is_test and not inline:
                out.test_children.add(m.group("modname").removeprefix("r#"))
        elif m.group("use"):
            end = code.find(";", m.end())
            end = len(code) if end < 0 else end
            if not skipped(m.start()):
                for segments, alias, glob in parse_use_tree(code[m.end() : end]):
                    text = "use " + snippet(m.end(), end)
                    out.uses.append((segments, alias, glob, len(inline), line_of(m.start()), text))
            pos = end + 1
        elif m.group("open"):
            depth += 1
        elif m.group("close"):
            if inline and inline[-1][0] == depth:
                inline.pop()
            depth -= 1
        elif m.group("path"):
            before = code[max(0, m.start() - 12) : m.start()]
            if re.search(r"\bin\s+$", before):  # pub(in crate::a): no import
                continue
            segments = [m.group("head").removeprefix("r#")]
            p = m.end("head")
            while True:
                t = PATH_TAIL.match(code, p)
                if not t:
                    break
                segments.append(t.group(1).removeprefix("r#"))
                p = t.end()
            if not (not tests and any(t for _, t in inline)):
                out.paths.append((segments, len(inline), line_of(m.start()), snippet(m.start(), p)))
            pos = p
    # what the file defines at its top level (not inside impls, functions or inline modules)
    depth = 0
    top = []
    for c in code:
        if c == "{":
            depth += 1
        elif c == "}":
            depth -= 1
        top.append(c if depth == 0 or c == "{" and depth == 1 else " ")
    for m in DEFINITION.finditer("".join(top)):
        name = next(g for g in m.groups() if g)
        out.definitions.add(name.removeprefix("r#"))
    return out


def rust_graph(crate: Path, name: str, tests: bool = False, parents: bool = False) -> Graph | None:
    src = crate / "src"
    modules = rust_modules(src)
    if not modules:
        return None
    files = {m: scan_rust(p, m, str(p.relative_to(crate)), tests) for m, p in modules.items()}
    # without tests, the modules a parent declares `#[cfg(test)]` go, and all below them
    test_modules = set()
    for m in files:
        for k in range(len(m)):
            parent = files.get(m[:k])
            if parent is not None and m[k] in parent.test_children:
                test_modules.add(m)
    for m in test_modules:
        del files[m]
        del modules[m]
    graph = Graph(
        f"{name} (Rust)",
        {m: f.rel for m, f in files.items()},
        label=lambda m: "::".join(m) if m else "crate",
        parents=parents,
    )

    def children(m: Module) -> set:
        return {k[-1] for k in modules if len(k) == len(m) + 1 and k[: len(m)] == m}

    def absolute(f: RustFile, segments: list, inline_depth: int, bindings: dict):
        """The path from the crate's root, or None for another crate's or a local name."""
        head = segments[0]
        if head in ("crate", "$crate"):
            return list(segments[1:])
        if head == "self":
            return list(f.module) + segments[1:]
        if head == "super":
            ups = 0
            while ups < len(segments) and segments[ups] == "super":
                ups += 1
            climb = ups - inline_depth
            if climb <= 0:
                return list(f.module) + segments[ups:]
            if climb > len(f.module):
                return None
            return list(f.module[: len(f.module) - climb]) + segments[ups:]
        if head in children(f.module):
            return list(f.module) + segments
        if head in bindings:
            return list(bindings[head]) + segments[1:]
        return None

    # each file's names bound by its top-level `use`s: name -> absolute path or None (external)
    names: dict = {}
    globs: dict = {}
    module_bindings: dict = {}  # name -> module path, for paths written in the code
    for m, f in files.items():
        names[m], globs[m], module_bindings[m] = {}, [], {}
        for segments, alias, glob, inline_depth, _, _ in f.uses:
            if inline_depth:
                continue
            target = absolute(f, segments, 0, {}) if segments else None
            if glob:
                if target is not None:
                    globs[m].append(target)
                continue
            if not segments:
                continue
            bound = alias or segments[-1]
            names[m][bound] = target
            if target is not None and tuple(target) in modules:
                module_bindings[m][bound] = tuple(target)

    def deepest(path: list):
        k = 0
        while k < len(path) and tuple(path[: k + 1]) in modules:
            k += 1
        return tuple(path[:k]), path[k:]

    def resolve(path: list, seen: int = 0):
        """The module an absolute path's item comes from; None if from another crate."""
        m, rest = deepest(path)
        if not rest or seen > 16:
            return m
        item = rest[0]
        if item in files[m].definitions:
            return m
        if item in names[m]:
            target = names[m][item]
            if target is None:
                return None
            return resolve(list(target) + rest[1:], seen + 1)
        for g in globs[m]:
            gm, grest = deepest(g)
            if not grest and (item in files[gm].definitions or item in names[gm]):
                return resolve(list(gm) + rest, seen + 1)
        return m

    for m, f in files.items():
        for segments, alias, glob, inline_depth, line, text in f.uses:
            if not segments:
                continue
            bindings = {} if inline_depth else module_bindings[m]
            target = absolute(f, segments, inline_depth, bindings)
            if target is None:
                continue
            to = deepest(target)[0] if glob else resolve(target)
            if to is not None:
                graph.imports.append(Import(m, to, f.rel, line, text))
        for segments, inline_depth, line, text in f.paths:
            head = segments[0]
            if head in ("crate", "$crate", "self", "super"):
                target = absolute(f, segments, inline_depth, {})
            elif head in children(m) or head in module_bindings[m]:
                target = absolute(f, segments, 0, module_bindings[m])
            else:
                continue
            if target is None:
                continue
            to = resolve(target)
            if to is not None:
                graph.imports.append(Import(m, to, f.rel, line, text))
    return graph


# -- Python -------------------------------------------------------------------------------


def python_graph(package: Path, crate: Path, name: str, parents: bool = False) -> Graph:
    top = package.name
    modules: dict = {}
    for path in sorted(package.rglob("*.py")) + sorted(package.rglob("*.pyi")):
        rel = path.relative_to(package).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts.pop()
        key = tuple(parts)
        if key not in modules:
            modules[key] = path
    graph = Graph(
        f"{name} (Python package {top})",
        {m: str(p.relative_to(crate)) for m, p in modules.items()},
        label=lambda m: ".".join((top,) + m),
        parents=parents,
    )

    def deepest(path: list) -> Module:
        k = 0
        while k < len(path) and tuple(path[: k + 1]) in modules:
            k += 1
        return tuple(path[:k])

    for m, path in modules.items():
        if path.suffix != ".py":
            continue
        is_package = path.name == "__init__.py"
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        rel = str(path.relative_to(crate))
        source = path.read_text(encoding="utf-8").splitlines()

        def add(target: list, node) -> None:
            text = source[node.lineno - 1].strip() if node.lineno <= len(source) else ""
            graph.imports.append(Import(m, deepest(target), rel, node.lineno, text))

        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    parts = alias.name.split(".")
                    if parts[0] == top:
                        add(parts[1:], node)
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = list(m) if is_package else list(m[:-1])
                    up = node.level - 1
                    if up > len(base):
                        continue
                    base = base[: len(base) - up]
                    if node.module:
                        base += node.module.split(".")
                else:
                    parts = (node.module or "").split(".")
                    if parts[0] != top:
                        continue
                    base = parts[1:]
                for alias in node.names:
                    add(base + [alias.name], node)
    return graph


# -- loops --------------------------------------------------------------------------------


def strongly_connected(edges: dict) -> list:
    """Tarjan's components (iterative), each a sorted list; only those of 2 or more."""
    index: dict = {}
    low: dict = {}
    on_stack: set = set()
    stack: list = []
    out = []
    counter = 0
    for start in sorted(edges):
        if start in index:
            continue
        work = [(start, iter(sorted(edges[start])))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(edges.get(w, ())))))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    component = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        component.append(w)
                        if w == v:
                            break
                    if len(component) > 1:
                        out.append(sorted(component))
    return sorted(out, key=lambda c: (-len(c), c))


def loops(graph: Graph) -> list:
    return strongly_connected(graph.edges())


def report(graph: Graph, all_edges: bool) -> int:
    """Prints the graph's loops; returns how many."""
    found = loops(graph)
    n_modules = len(graph.modules)
    if not found:
        print(f"{graph.name}, {n_modules} modules: no loops")
        return 0
    print(f"{graph.name}, {n_modules} modules: {len(found)} loop(s)")
    for k, component in enumerate(found, 1):
        members = set(component)
        names = ", ".join(graph.label(m) for m in component)
        print(f"  loop {k}, {len(component)} modules: {names}")
        inside: dict = {}
        for imp in graph.imports:
            if imp.source in members and imp.target in members and graph.counts(imp):
                inside.setdefault((imp.source, imp.target), []).append(imp)
        for (a, b), imps in sorted(inside.items()):
            shown = imps if all_edges else imps[:1]
            more = "" if all_edges or len(imps) == 1 else f" (and {len(imps) - 1} more)"
            for imp in shown:
                where = f"{imp.file}:{imp.line}: {imp.text}"
                print(f"    {graph.label(a)} -> {graph.label(b)}: {where}{more}")
                more = ""
    return len(found)


def layer_of(module: Module, layers: list) -> int:
    """A module's layer: the index in `layers` (bottom first) of its top-level module, or
    `len(layers)` (the top) for every other module and the crate's root."""
    if module and module[0] in layers:
        return layers.index(module[0])
    return len(layers)


def breaches(graph: Graph, layers: list) -> list:
    """The imports of a module from a layer above its own (`layers`: top-level module
    names, bottom first; the rest of the crate is the top)."""
    return [
        imp
        for imp in graph.imports
        if graph.counts(imp) and layer_of(imp.source, layers) < layer_of(imp.target, layers)
    ]


def report_layers(graph: Graph, layers: list) -> int:
    """Prints the imports that reach up a layer; returns how many."""
    found = breaches(graph, layers)
    names = " < ".join(layers + ["the rest"])
    if not found:
        print(f"{graph.name}: layers {names}: no import reaches up")
        return 0
    print(f"{graph.name}: layers {names}: {len(found)} import(s) reach up")
    for imp in found:
        a, b = graph.label(imp.source), graph.label(imp.target)
        print(f"    {a} -> {b}: {imp.file}:{imp.line}: {imp.text}")
    return len(found)


def crates(root: Path) -> list:
    """The crate folders of the repository (a Cargo.toml and a src/), sorted."""
    out = []
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = sorted(
            d
            for d in dirnames
            if d not in ("target", "node_modules", ".git") and not d.startswith(".")
        )
        if "Cargo.toml" in filenames and (Path(dirpath) / "src").is_dir():
            out.append(Path(dirpath))
    return sorted(out)


def graphs(crate: Path, root: Path, tests: bool = False, parents: bool = False) -> list:
    """The crate's Rust graph (if it has a src/lib.rs or src/main.rs) and its Python packages'."""
    name = str(crate.relative_to(root)) if crate.is_relative_to(root) else str(crate)
    out = []
    g = rust_graph(crate, name, tests, parents)
    if g is not None:
        out.append(g)
    python = crate / "python"
    if python.is_dir():
        for package in sorted(python.iterdir()):
            if (package / "__init__.py").exists():
                out.append(python_graph(package, crate, name, parents))
    return out


def main(argv: list | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("crates", nargs="*", help="crate folders or names (default: all)")
    parser.add_argument(
        "--exclude", action="append", default=[], help="a crate folder or name to skip"
    )
    parser.add_argument(
        "--root",
        type=Path,
        default=Path(__file__).resolve().parent.parent,
        help="the repository (default: this one)",
    )
    parser.add_argument(
        "--edges", action="store_true", help="every import inside each loop, not the first"
    )
    parser.add_argument("--tests", action="store_true", help="read #[cfg(test)] code too")
    parser.add_argument(
        "--parents", action="store_true", help="count a module's imports of its own ancestors too"
    )
    parser.add_argument(
        "--layers",
        action="append",
        default=[],
        metavar="CRATE=BOTTOM,MIDDLE,...",
        help="also refuse an import from a layer to one above it: the crate's top-level "
        "modules, bottom first, the rest of the crate being the top",
    )
    args = parser.parse_args(argv)
    root = args.root.resolve()
    every = crates(root)

    def find(given: str) -> Path:
        for base in (Path.cwd(), root):
            p = (base / given).resolve()
            if p in every:
                return p
        named = [c for c in every if c.name == given]
        if len(named) == 1:
            return named[0]
        parser.error(f"no crate {given!r} under {root}")

    layered = {}
    for spec in args.layers:
        given, _, names = spec.partition("=")
        if not names:
            parser.error(f"--layers {spec!r}: give CRATE=BOTTOM,MIDDLE,...")
        layered[find(given)] = [n for n in names.split(",") if n]
    chosen = [find(c) for c in args.crates] if args.crates else every
    skipped = {find(c) for c in args.exclude}
    chosen = [c for c in chosen if c not in skipped]
    total = 0
    units = 0
    reaching_up = 0
    for crate in chosen:
        for g in graphs(crate, root, args.tests, args.parents):
            units += 1
            total += report(g, args.edges)
            if crate in layered and g.name.endswith("(Rust)"):
                reaching_up += report_layers(g, layered[crate])
    if skipped:
        print("not checked: " + ", ".join(str(c.relative_to(root)) for c in sorted(skipped)))
    if reaching_up:
        print(f"imports reaching up a layer: {reaching_up}")
    if total:
        print(f"import loops: {total} in {units} crates and packages checked")
        return 1
    if reaching_up:
        return 1
    print(f"import loops: none in {units} crates and packages checked")
    return 0


if __name__ == "__main__":
    sys.exit(main())
