#!/usr/bin/env python3
"""Import cycles between the modules of every crate, at every folder level,
and the host's wing order.

For each folder module (a crate root, `sense/track/`, `field/`, ...) the nodes
are its direct children and an edge a -> b means code under a names b
through `crate::`, `super::` or `self::` paths. Any cycle between siblings (a
mutual pair or a longer loop) is printed and the exit status is 1; 0 means
none. Test code (`tests.rs`, `tests/`, a trailing `#[cfg(test)] mod tests`)
is skipped.

The host library (`host/src`) is grouped into wings that import only
downwards (ARCHITECTURE.md): base < plan < field < device < sense < lab,
where base is every other top-level module. An import from a lower wing into
a higher one is printed and fails too.

Usage: module_cycles.py [SRC_DIR ...] (default: every crate's source folder).
"""
import os
import re
import sys

CRATES = ['proto/src', 'firmware/core/src', 'firmware/qemu/src', 'firmware/nucleo-h743/src',
          'firmware/nucleo-h743/logic/src',
          'host/src', 'cli/src', 'python/src', 'xtask/src']
#: The host's wings, lowest first; every other top-level module is base.
WINGS = {'host/src': ['plan', 'field', 'device', 'sense', 'lab']}

PATH = re.compile(r'\b((?:crate|super|self)(?:::\w+)+|(?:crate|super|self)::\{[^}]*\})')


def module_path(rel):
    """`sense/track/source.rs` -> ['sense', 'track', 'source']; `x/mod.rs` -> ['x']."""
    parts = rel[:-3].split(os.sep)
    if parts[-1] in ('mod', 'lib', 'main'):
        parts = parts[:-1]
    return parts


def expand(path):
    """`super::{a, b::c}` -> ['super::a', 'super::b::c'] (one level of braces)."""
    m = re.match(r'(.*)::\{([^}]*)\}$', path)
    if not m:
        return [path]
    return [m.group(1) + '::' + p.strip() for p in m.group(2).split(',') if p.strip()]


def resolve(mp, path):
    segs = path.split('::')
    if segs[0] == 'crate':
        return segs[1:]
    # A plain file's own module is mp; `super` is its parent.
    base = list(mp)
    i = 1 if segs[0] == 'self' else 0
    while i < len(segs) and segs[i] == 'super':
        base = base[:-1]
        i += 1
    return base + segs[i:]


def sources(root):
    """(path, module path) of every non-test source file under `root`."""
    out = []
    for dp, _, fn in os.walk(root):
        for f in fn:
            if not f.endswith('.rs'):
                continue
            rel = os.path.relpath(os.path.join(dp, f), root)
            if f == 'tests.rs' or os.sep + 'tests' + os.sep in os.sep + rel:
                continue
            mp = module_path(rel)
            if mp and mp[0] == 'bin':
                continue
            out.append((os.path.join(dp, f), mp))
    return out


def code(path):
    text = open(path, encoding='utf-8').read()
    i = text.find('#[cfg(test)]\nmod tests')
    if i >= 0:
        text = text[:i]
    return '\n'.join(l for l in text.split('\n') if not l.lstrip().startswith('//'))


def cycles(g):
    """Strongly connected components of more than one node (Tarjan)."""
    idx, low, st, on, comps, c = {}, {}, [], set(), [], [0]

    def sc(v):
        idx[v] = low[v] = c[0]
        c[0] += 1
        st.append(v)
        on.add(v)
        for w in g.get(v, ()):
            if w not in idx:
                sc(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], idx[w])
        if low[v] == idx[v]:
            comp = []
            while True:
                w = st.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(sorted(comp))

    for v in list(g):
        if v not in idx:
            sc(v)
    return comps


def check(root):
    """Prints the cycles and wing violations under `root`; returns (found, levels)."""
    files = sources(root)
    children = {}  # folder module path (tuple) -> set of child names
    for _, mp in files:
        for k in range(len(mp)):
            children.setdefault(tuple(mp[:k]), set()).add(mp[k])
    wings = WINGS.get(root, [])
    rank = {w: i + 1 for i, w in enumerate(wings)}
    edges = {}  # folder -> {a: set(b)}
    found = 0
    for p, mp in files:
        for raw in PATH.findall(code(p)):
            for path in expand(raw):
                target = resolve(mp, path)
                # First place where the two module paths part: siblings there.
                for k in range(min(len(mp), len(target))):
                    if mp[k] != target[k]:
                        folder = tuple(mp[:k])
                        if target[k] in children.get(folder, ()):
                            edges.setdefault(folder, {}).setdefault(mp[k], set()).add(target[k])
                            if k == 0 and rank.get(mp[0], 0) < rank.get(target[0], 0):
                                found += 1
                                print(f'wing order in {root}: {p} imports {path} '
                                      f'({mp[0] if mp[0] in rank else "base"} is below {target[0]})')
                        break
    for folder in sorted(edges):
        g = edges[folder]
        where = '::'.join(folder) or 'crate'
        for comp in cycles(g):
            found += 1
            print(f'cycle in {root} {where}: ' + ' '.join(comp))
            for a in comp:
                print('   ', a, '->', ' '.join(sorted(d for d in g.get(a, ()) if d in comp)))
    return found, len(edges)


def main():
    sys.setrecursionlimit(10000)
    roots = sys.argv[1:] or [r for r in CRATES if os.path.isdir(r)]
    found = levels = 0
    for root in roots:
        f, l = check(root)
        found += f
        levels += l
    print(f'module cycles and wing-order breaks: {found} in {levels} folder levels of {len(roots)} crates')
    sys.exit(1 if found else 0)


main()
