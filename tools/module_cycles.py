#!/usr/bin/env python3
"""Checks that the controller library's top-level modules import each other without a circle.

Reads every `.rs` file under `src/`, takes the `crate::<module>` paths it names outside
comments and unit-test modules (`#[cfg(test)]` or `#[cfg(all(test, …))]` before `mod`),
with nested `crate::{…}` groups and the crate root's re-exports (`crate::Stepper` is
`stepper`'s) resolved, and builds the graph
"module A names module B" over the crate's top-level modules. The test bench (the
`reference` feature's reference solvers, scenarios and verification tools) builds on the
library and is left out: its files are those under `src/testbench/` (TEST_BENCH), and the
re-exports that keep its old public paths (`crate::testbench::…` named from `lib.rs`, `nd`,
`stability`, `limits_nd`) are not edges. Prints the graph's strongly connected components
of more than one module and exits with status 1 if there is one.

    python3 tools/module_cycles.py [--graph]
"""

import os
import re
import sys

SRC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src")

# The test bench's folder under src/ (compiled with the `reference` feature only).
TEST_BENCH = "testbench"


def top_modules():
    names = set()
    for entry in os.listdir(SRC):
        if entry.endswith(".rs"):
            names.add(entry[:-3])
        elif os.path.isdir(os.path.join(SRC, entry)):
            names.add(entry)
    return names - {"lib", "main", TEST_BENCH}


def edges(modules):
    graph = {}
    root_items = crate_root_items()
    for folder, _, files in os.walk(SRC):
        for name in files:
            if not name.endswith(".rs"):
                continue
            rel = os.path.relpath(os.path.join(folder, name), SRC).replace(os.sep, "/")
            if rel.startswith(TEST_BENCH + "/"):
                continue
            module = rel.split("/")[0].removesuffix(".rs")
            if module not in modules:
                continue
            text = open(os.path.join(folder, name), encoding="utf-8").read()
            text = re.sub(r"//.*", "", text)
            text = without_unit_tests(text)
            named = set()
            for path in re.findall(r"crate::([A-Za-z_0-9]+)", text):
                named.add(root_items.get(path, path))
            for group in brace_groups(text):
                for head in top_level_heads(group):
                    named.add(root_items.get(head, head))
            graph.setdefault(module, set()).update(named & modules - {module})
    return graph


# A unit-test module: `#[cfg(test)]` or `#[cfg(all(test, …))]` before `mod NAME {`.
TEST_MODULE = re.compile(r"#\[cfg\((?:test|all\(test[^\]]*)\)\]\s*mod\s+\w+\s*\{")
# A unit-test file declared from here: `#[cfg(test)] mod NAME;` (its own file is read apart).
TEST_FILE = re.compile(r"#\[cfg\((?:test|all\(test[^\]]*)\)\]\s*mod\s+\w+\s*;")


def without_unit_tests(text):
    """`text` without its inline unit-test modules (their braces matched) and test-file lines."""
    text = TEST_FILE.sub("", text)
    while True:
        match = TEST_MODULE.search(text)
        if not match:
            return text
        depth, end = 1, match.end()
        while end < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[end], 0)
            end += 1
        text = text[: match.start()] + text[end:]


def brace_groups(text):
    """The contents of every `crate::{…}`, nested braces included."""
    for match in re.finditer(r"crate::\{", text):
        depth, end = 1, match.end()
        while end < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[end], 0)
            end += 1
        yield text[match.end() : end - 1]


def top_level_heads(group):
    """The first path segment of each comma-separated item at the group's top level."""
    depth, item, items = 0, "", []
    for ch in group:
        if ch == "," and depth == 0:
            items.append(item)
            item = ""
            continue
        depth += {"{": 1, "}": -1}.get(ch, 0)
        item += ch
    items.append(item)
    return [m.group(1) for m in (re.match(r"\s*([A-Za-z_0-9]+)", i) for i in items) if m]


def crate_root_items():
    """The names `lib.rs` re-exports (`pub use module::{A, B}`), mapped to their module."""
    text = re.sub(r"//.*", "", open(os.path.join(SRC, "lib.rs"), encoding="utf-8").read())
    items = {}
    for module, rest in re.findall(r"pub use ([a-z_0-9]+)::(\{[^;]*\}|[A-Za-z_0-9]+);", text):
        for name in re.findall(r"[A-Za-z_0-9]+", rest):
            items.setdefault(name, module)
    return items


def circles(graph):
    """Tarjan's strongly connected components with more than one module."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
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

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def main():
    graph = edges(top_modules())
    if "--graph" in sys.argv:
        for module in sorted(graph):
            print(f"{module} -> {', '.join(sorted(graph[module])) or '(nothing)'}")
    found = circles(graph)
    for component in found:
        print("import circle:", " <-> ".join(component))
        for module in component:
            print(f"  {module} -> {', '.join(sorted(graph[module] & set(component)))}")
    if found:
        return 1
    print(f"no import circle among the library's {len(graph)} top-level modules")
    return 0


if __name__ == "__main__":
    sys.exit(main())
