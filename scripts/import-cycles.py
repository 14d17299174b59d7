#!/usr/bin/env python3
"""Import circles between the source files of each crate, and long files.

For every crate under crates/*/src, each file is one node: `lib.rs` /
`main.rs` is the crate root, `foo.rs` and `foo/mod.rs` are module `foo`,
`foo/bar.rs` is `foo::bar`. An edge A -> B means A's code (before its
`#[cfg(test)]` module; comments and strings ignored) names an item of B:
`use crate::b::...`, `crate::b::...`, `super::...`, `self::...`, or a
child module's name in its parent. A path through a module that
re-exports the item (`pub use`) is followed to the file that defines it.
A `pub use` of a module's own submodule (a `mod.rs` or `lib.rs` facade),
or of a name the file's own code does not use (a module re-exporting a
helper's types), is an alias, not a dependency: who names the item
through it depends on the defining file.
Files and modules under `#[cfg(test)]` (`tests.rs`) are left out.

Reports every strongly connected component of more than one file (a
circle) and exits 1 if there is any.

usage:
  import-cycles.py [--crate NAME] [ROOT]         circles in ROOT/crates/*/src (ROOT: .)
  import-cycles.py --long [--crate NAME] [ROOT]  files over 600 lines before their tests
"""

import re
import sys
from pathlib import Path

LIMIT = 600
IDENT = r"[A-Za-z_][A-Za-z0-9_]*"


def code_before_tests(text):
    """The lines before the file's `#[cfg(test)]` module."""
    lines = text.split("\n")
    for i, line in enumerate(lines):
        if line.strip() == "#[cfg(test)]":
            for nxt in lines[i + 1 : i + 4]:
                s = nxt.strip()
                if s.startswith("#["):
                    continue
                if re.match(r"(pub(\([^)]*\))?\s+)?mod\s", s):
                    return lines[:i]
                break
    return lines


def strip_comments_and_strings(src):
    """Source with comments removed and string/char literals emptied."""
    out = []
    i, n = 0, len(src)
    while i < n:
        c = src[i]
        if src.startswith("//", i):
            j = src.find("\n", i)
            i = n if j < 0 else j
        elif src.startswith("/*", i):
            depth, i = 1, i + 2
            while i < n and depth:
                if src.startswith("/*", i):
                    depth, i = depth + 1, i + 2
                elif src.startswith("*/", i):
                    depth, i = depth - 1, i + 2
                else:
                    i += 1
        elif c == "r" and re.match(r'r#*"', src[i:]) and (i == 0 or not (src[i - 1].isalnum() or src[i - 1] == "_")):
            m = re.match(r'r(#*)"', src[i:])
            end = '"' + m.group(1)
            j = src.find(end, i + len(m.group(0)))
            out.append('""')
            i = n if j < 0 else j + len(end)
        elif c == '"':
            i += 1
            while i < n and src[i] != '"':
                i += 2 if src[i] == "\\" else 1
            out.append('""')
            i += 1
        elif c == "'":
            # a char literal ('a', '\n', '\u{..}') or a lifetime ('a)
            m = re.match(r"'(\\u\{[0-9a-fA-F]+\}|\\.|[^\\'])'", src[i:])
            if m:
                out.append("' '")
                i += len(m.group(0))
            else:
                out.append(c)
                i += 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def module_of(src_dir, path):
    rel = path.relative_to(src_dir).with_suffix("")
    parts = list(rel.parts)
    if parts in (["lib"], ["main"]):
        return ()
    if parts[-1] == "mod":
        parts = parts[:-1]
    return tuple(parts)


def expand_use_tree(tree):
    """`a::{b, c::{d, e as f}, self}` -> [[a,b],[a,c,d],[a,c,e],[a]]."""
    tree = re.sub(r"\s+as\s+" + IDENT, "", tree)
    tree = re.sub(r"\s+", "", tree)
    out = []

    def walk(prefix, s):
        depth, start, items = 0, 0, []
        for k, ch in enumerate(s):
            if ch == "{":
                depth += 1
            elif ch == "}":
                depth -= 1
            elif ch == "," and depth == 0:
                items.append(s[start:k])
                start = k + 1
        items.append(s[start:])
        for item in items:
            if not item:
                continue
            if "{" in item:
                head, rest = item.split("{", 1)
                head_parts = [p for p in head.split("::") if p]
                walk(prefix + head_parts, rest[: rest.rfind("}")])
            else:
                parts = [p for p in item.split("::") if p]
                if parts and parts[-1] == "self":
                    parts = parts[:-1]
                out.append(prefix + parts)

    walk([], tree)
    return out


class Crate:
    def __init__(self, src_dir):
        self.src_dir = src_dir
        self.files = {}  # module path -> file
        for path in sorted(src_dir.rglob("*.rs")):
            if path.name == "tests.rs" or "tests" in path.relative_to(src_dir).parts[:-1]:
                continue
            if path.parent == src_dir / "bin":
                continue
            mod = module_of(src_dir, path)
            if mod == () and () in self.files:
                continue  # a crate with both lib.rs and main.rs: keep lib.rs
            self.files[mod] = path
        self.code = {m: strip_comments_and_strings("\n".join(code_before_tests(p.read_text()))) for m, p in self.files.items()}
        self.uses = {m: self._uses(c) for m, c in self.code.items()}
        # module -> {name: absolute path it re-exports}
        self.reexports = {m: {} for m in self.files}
        for m, uses in self.uses.items():
            for public, parts in uses:
                if public and parts:
                    absolute = self.absolute(m, parts)
                    if absolute is not None:
                        self.reexports[m][parts[-1]] = absolute

    @staticmethod
    def _uses(code):
        out = []
        for m in re.finditer(r"(?:^|[;{}\s])(pub(?:\([^)]*\))?\s+)?use\s+([^;]+);", code):
            for parts in expand_use_tree(m.group(2)):
                out.append((bool(m.group(1)), parts))
        return out

    def children(self, mod):
        return {k[len(mod)] for k in self.files if len(k) == len(mod) + 1 and k[: len(mod)] == mod}

    def absolute(self, mod, parts):
        """An absolute path (tuple) for `parts` written in module `mod`, or None (extern)."""
        parts = list(parts)
        if not parts:
            return None
        if parts[0] == "crate":
            return tuple(parts[1:])
        base = list(mod)
        if parts[0] == "self":
            return tuple(base + parts[1:])
        if parts[0] == "super":
            while parts and parts[0] == "super":
                if not base:
                    return None
                base.pop()
                parts.pop(0)
            return tuple(base + parts)
        if parts[0] in self.children(mod):
            return tuple(list(mod) + parts)
        return None

    def resolve(self, path, depth=0):
        """The module (file) defining the item at absolute `path`."""
        for k in range(len(path), -1, -1):
            if path[:k] in self.files:
                mod, rest = path[:k], path[k:]
                if rest and depth < 16 and rest[0] in self.reexports[mod]:
                    target = self.reexports[mod][rest[0]] + tuple(rest[1:])
                    if target != path:
                        return self.resolve(target, depth + 1)
                return mod
        return None

    def edges(self):
        graph = {m: set() for m in self.files}
        for m, code in self.code.items():
            body = re.sub(r"(?:^|[;{}\s])(pub(?:\([^)]*\))?\s+)?use\s+[^;]+;", " ", code)
            paths = []
            for public, parts in self.uses[m]:
                absolute = self.absolute(m, parts)
                if absolute is None:
                    continue
                alias_only = public and not re.search(r"(?<![A-Za-z0-9_])" + re.escape(parts[-1]) + r"(?![A-Za-z0-9_])", body)
                facade = public and len(absolute) > len(m) and absolute[: len(m)] == m
                if not (alias_only or facade):
                    paths.append(absolute)
            for p in re.finditer(r"(?<![A-Za-z0-9_:])((?:" + IDENT + r"::)+" + IDENT + ")", body):
                absolute = self.absolute(m, p.group(1).split("::"))
                if absolute is not None:
                    paths.append(absolute)
            for absolute in paths:
                target = self.resolve(absolute)
                if target is not None and target != m:
                    graph[m].add(target)
        return graph

    def name(self, mod):
        return str(self.files[mod].relative_to(self.src_dir))


def strongly_connected(graph):
    index, low, stack, on, comps = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
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
            comps.append(comp)

    sys.setrecursionlimit(10000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return comps


def circles(root, only="*"):
    found = 0
    for src_dir in sorted(root.glob(f"crates/{only}/src")):
        crate = Crate(src_dir)
        graph = crate.edges()
        for comp in strongly_connected(graph):
            if len(comp) < 2:
                continue
            found += 1
            members = set(comp)
            parents = [p for p in comp if all(m[: len(p)] == p for m in comp)]
            kind = f" (through the parent {crate.name(parents[0])})" if parents else ""
            print(f"{src_dir.parent.name}: circle of {len(comp)} files{kind}")
            for m in sorted(comp, key=crate.name):
                inside = sorted(crate.name(t) for t in graph[m] if t in members)
                print(f"  {crate.name(m)} -> {', '.join(inside)}")
    if not found:
        print("no import circles")
    return 1 if found else 0


def long_files(root, only="*"):
    found = 0
    for path in sorted(root.glob(f"crates/{only}/src/**/*.rs")):
        if path.name == "tests.rs":
            continue
        n = len(code_before_tests(path.read_text()))
        if path.read_text().endswith("\n"):
            n -= 1
        if n > LIMIT:
            found += 1
            print(f"{n:5d} {path.relative_to(root)}")
    if not found:
        print(f"no source file over {LIMIT} lines before its tests")
    return 1 if found else 0


def main(argv):
    long = "--long" in argv
    rest = [a for a in argv if a != "--long"]
    only = "*"
    if "--crate" in rest:
        k = rest.index("--crate")
        only = rest[k + 1]
        del rest[k : k + 2]
    root = Path(rest[0]) if rest else Path(".")
    return long_files(root, only) if long else circles(root, only)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
