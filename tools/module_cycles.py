#!/usr/bin/env python3
"""Checks that the controller library's top-level modules import each other without a circle.

Reads every `.rs` file under `src/`, takes the `crate::<module>` paths it names outside
comments and outside its unit tests (from its first `#[cfg(test)]` or
`#[cfg(all(test, …))]` on), and builds the graph
"module A names module B" over the crate's top-level modules. The test bench (the
`reference` feature's reference solvers, scenarios and verification tools) builds on the
library and is left out: its files are listed in TEST_BENCH. Prints the graph's strongly
connected components of more than one module and exits with status 1 if there is one.

    python3 tools/module_cycles.py [--graph]
"""

import os
import re
import sys

SRC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src")

# Paths under src/ that belong to the test bench (compiled with the `reference` feature only).
TEST_BENCH = (
    "mpm", "scenario", "problems", "memory",
    "nd/fused", "nd/material", "nd/migration", "nd/particles", "nd/problems",
    "nd/scenario", "nd/slab", "nd/solver", "nd/threaded", "nd/update",
    "stability/empirical", "limits_nd/critical",
)


def top_modules():
    names = set()
    for entry in os.listdir(SRC):
        if entry.endswith(".rs"):
            names.add(entry[:-3])
        elif os.path.isdir(os.path.join(SRC, entry)):
            names.add(entry)
    return names - {"lib", "main"}


def edges(modules):
    graph = {}
    for folder, _, files in os.walk(SRC):
        for name in files:
            if not name.endswith(".rs"):
                continue
            rel = os.path.relpath(os.path.join(folder, name), SRC).replace(os.sep, "/")
            if rel.startswith(TEST_BENCH):
                continue
            module = rel.split("/")[0].removesuffix(".rs")
            if module not in modules:
                continue
            text = open(os.path.join(folder, name), encoding="utf-8").read()
            cuts = [i for i in (text.find("#[cfg(test)]"), text.find("#[cfg(all(test")) if i >= 0]
            if cuts:
                text = text[: min(cuts)]
            text = re.sub(r"//.*", "", text)
            named = set(re.findall(r"crate::([a-z_0-9]+)", text))
            for group in re.findall(r"crate::\{([^}]*)\}", text):
                named |= set(re.findall(r"(?:^|,)\s*([a-z_0-9]+)", group))
            graph.setdefault(module, set()).update(named & modules - {module})
    return graph


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
