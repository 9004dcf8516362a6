#!/usr/bin/env python3
"""Module dependency graph of src/ (issue 12).

Reads every .rs file under src/, drops comments, and collects the crate's
top-level modules each one names: `crate::m` (also inside `use crate::{..}`
groups), and `deformesh::m` in the binary (main.rs, bench). A file belongs
to the top-level module of its path (src/io/msh.rs -> io; src/main.rs ->
main). Files named tests.rs and `#[cfg(test)] mod tests` blocks are test
code: their edges are listed apart and not judged.

Prints: lines per module and layer, the graph (module -> modules it uses),
and the edges that break the target layering of issue 12:

  application  main lib app (case, bind, driver, bench)   may use anything
  method       deform (Alg. 1) <- refine (Alg. 2) <- highorder (Alg. 3)
               core, and only down that chain
  io / render  io render                              core only
  core         lsfem solve mesh geometry numeric expr jacobian quality
               core only, and no cycles

Options: --mermaid prints a mermaid graph instead of the text listing;
--check exits 1 when an edge breaks the layering or modules form a cycle.
"""
import os
import re
import sys
from collections import defaultdict

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src")

LAYER = {
    "main": "application", "lib": "application", "app": "application",
    "deform": "method", "refine": "method", "highorder": "method",
    "io": "io/render", "render": "io/render",
}
CORE = ["lsfem", "solve", "mesh", "geometry", "geometry3", "numeric", "expr",
        "jacobian", "quality"]
for m in CORE:
    LAYER[m] = "core"
METHOD = ["deform", "refine", "highorder"]  # Algorithms 1, 2, 3
RANK = {"core": 0, "io/render": 1, "method": 2, "application": 3}
ORDER = ["application", "method", "io/render", "core"]


def strip_comments(text):
    # block comments, then line comments (keeps string contents good enough
    # for this purpose: no `crate::` appears inside string literals here)
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return "\n".join(re.sub(r"//.*", "", line) for line in text.splitlines())


def split_test_code(text):
    """(non-test, test) parts: a `#[cfg(test)] mod x { .. }` block is test."""
    m = re.search(r"#\[cfg\(test\)\]\s*(pub\s+)?mod\s+\w+\s*\{", text)
    if not m:
        return text, ""
    depth, i = 1, m.end()
    while i < len(text) and depth:
        depth += {"{": 1, "}": -1}.get(text[i], 0)
        i += 1
    rest, test = split_test_code(text[i:])
    return text[: m.start()] + rest, text[m.start():i] + test


def group_items(text, start):
    """Top-level names of the `{a::b, c, d::{..}}` group opening at start."""
    depth, i, cur, names = 0, start, "", []
    while i < len(text):
        c = text[i]
        if c == "{":
            depth += 1
            if depth == 1:
                i += 1
                continue
        elif c == "}":
            depth -= 1
            if depth == 0:
                names.append(cur)
                break
        if depth == 1 and c == ",":
            names.append(cur)
            cur = ""
        elif depth >= 1:
            cur += c
        i += 1
    out = []
    for n in names:
        m = re.match(r"\s*(\w+)", n)
        if m and m.group(1) != "self":
            out.append(m.group(1))
    return out


def uses(text, prefixes):
    found = set()
    for p in prefixes:
        for m in re.finditer(r"\b" + p + r"::(\w+|\{)", text):
            if m.group(1) == "{":
                found.update(group_items(text, m.end() - 1))
            else:
                found.add(m.group(1))
    return found


def module_of(rel):
    parts = rel.split(os.sep)
    return parts[0] if len(parts) > 1 else parts[0][:-3]


def main():
    mermaid = "--mermaid" in sys.argv
    edges = defaultdict(set)        # module -> used modules (non-test)
    test_edges = defaultdict(set)
    lines = defaultdict(int)
    files = []
    for d, _, fs in os.walk(ROOT):
        for f in fs:
            if f.endswith(".rs"):
                files.append(os.path.relpath(os.path.join(d, f), ROOT))
    modules = {module_of(r) for r in files}
    for rel in sorted(files):
        mod = module_of(rel)
        raw = open(os.path.join(ROOT, rel), encoding="utf-8").read()
        lines[mod] += raw.count("\n")
        text = strip_comments(raw)
        prefixes = ["crate"] + (["deformesh"] if mod in ("main",) else [])
        body, test = (("", text) if os.path.basename(rel) == "tests.rs" else split_test_code(text))
        for u in uses(body, prefixes):
            if u in modules and u != mod:
                edges[mod].add(u)
        for u in uses(test, prefixes):
            if u in modules and u != mod and u not in edges[mod]:
                test_edges[mod].add(u)
    for m in modules:
        LAYER.setdefault(m, "unassigned")
        RANK.setdefault("unassigned", -1)

    def bad(a, b):
        la, lb = LAYER[a], LAYER[b]
        if la == "application":
            return None
        if la == "method":
            if lb == "application":
                return "upward"
            if lb == "io/render":
                return "method uses io/render"
            if lb == "method" and METHOD.index(b) > METHOD.index(a):
                return f"upward ({a} is below {b})"
            return None
        if la == "io/render":
            if lb in ("application", "method"):
                return "upward"
            if lb == "io/render":
                return "sideways (io/render use only the mesh)"
            return None
        if la == "core" and lb != "core":
            return "upward"
        return None

    # cycles: strongly connected components of the non-test graph
    index, low, stack, on, comps, counter = {}, {}, [], set(), [], [0]

    def strong(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(edges[v]):
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
                comps.append(sorted(comp))

    for v in sorted(modules):
        if v not in index:
            strong(v)

    ordered = sorted(modules, key=lambda m: (ORDER.index(LAYER[m]) if LAYER[m] in ORDER else 9, m))
    if mermaid:
        print("graph TD")
        for layer in ORDER:
            ms = [m for m in ordered if LAYER[m] == layer]
            print(f'  subgraph {layer.replace("/", "_")}["{layer}"]')
            for m in ms:
                print(f"    {m}")
            print("  end")
        for a in ordered:
            for b in sorted(edges[a]):
                arrow = "-.->|" + bad(a, b) .split(" ")[0] + "|" if bad(a, b) else "-->"
                print(f"  {a} {arrow} {b}")
        return
    print("# lines per layer and module (wc -l of src/)")
    total = 0
    for layer in ORDER:
        ms = [m for m in ordered if LAYER[m] == layer]
        n = sum(lines[m] for m in ms)
        total += n
        print(f"{layer:12} {n:6}   " + ", ".join(f"{m} {lines[m]}" for m in ms))
    print(f"{'total':12} {total:6}")
    print()
    print("# module -> modules it uses (non-test code)")
    for a in ordered:
        print(f"{a:10} [{LAYER[a]}] -> " + ", ".join(sorted(edges[a])))
    print()
    print("# used only by test code")
    for a in ordered:
        if test_edges[a]:
            print(f"{a:10} -> " + ", ".join(sorted(test_edges[a])))
    print()
    print("# edges against the target layering")
    n = 0
    for a in ordered:
        for b in sorted(edges[a]):
            why = bad(a, b)
            if why:
                n += 1
                print(f"{a} ({LAYER[a]}) -> {b} ({LAYER[b]}): {why}")
    print(f"{n} edges")
    print()
    print("# cycles (strongly connected modules)")
    for c in comps:
        pairs = [f"{a} <-> {b}" for i, a in enumerate(c) for b in c[i + 1:] if b in edges[a] and a in edges[b]]
        print(", ".join(c) + ("   (mutual: " + "; ".join(pairs) + ")" if pairs else ""))
    if not comps:
        print("none")
    if "--check" in sys.argv and (n or comps):
        sys.exit(1)


if __name__ == "__main__":
    main()
