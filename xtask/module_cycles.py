#!/usr/bin/env python3
"""Import cycles between the modules of a crate, at every folder level.

For each folder module (the crate root, `track/`, `field/`, ...) the nodes are
its direct children and an edge a -> b means code under a names b through
`crate::`, `super::` or `self::` paths. Any cycle between siblings (a mutual
pair or a longer loop) is printed and the exit status is 1; 0 means none.
Test code (`tests.rs`, `tests/`, a trailing `#[cfg(test)] mod tests`) is
skipped. Usage: module_cycles.py [host/src]
"""
import os
import re
import sys

root = sys.argv[1] if len(sys.argv) > 1 else 'host/src'


def module_path(rel):
    """`track/source.rs` -> ['track', 'source']; `track/mod.rs` -> ['track']."""
    parts = rel[:-3].split(os.sep)
    if parts[-1] in ('mod', 'lib', 'main'):
        parts = parts[:-1]
    return parts


children = {}  # folder module path (tuple) -> set of child names
files = []
for dp, dn, fn in os.walk(root):
    for f in fn:
        if not f.endswith('.rs'):
            continue
        rel = os.path.relpath(os.path.join(dp, f), root)
        if f == 'tests.rs' or os.sep + 'tests' + os.sep in os.sep + rel:
            continue
        mp = module_path(rel)
        if rel in ('main.rs',) or (len(mp) >= 1 and mp[0] == 'bin'):
            continue
        files.append((os.path.join(dp, f), rel, mp))
        for k in range(len(mp)):
            children.setdefault(tuple(mp[:k]), set()).add(mp[k])

PATH = re.compile(r'\b((?:crate|super|self)(?:::\w+)+|(?:crate|super|self)::\{[^}]*\})')


def expand(path):
    """`super::{a, b::c}` -> ['super::a', 'super::b::c'] (one level of braces)."""
    m = re.match(r'(.*)::\{([^}]*)\}$', path)
    if not m:
        return [path]
    return [m.group(1) + '::' + p.strip() for p in m.group(2).split(',') if p.strip()]


def resolve(mp, is_mod_file, path):
    segs = path.split('::')
    if segs[0] == 'crate':
        return segs[1:]
    # A plain file's own module is mp; `super` is its parent.
    base = list(mp)
    i = 0
    if segs[0] == 'self':
        i = 1
    while i < len(segs) and segs[i] == 'super':
        base = base[:-1]
        i += 1
    return base + segs[i:]


edges = {}  # folder -> {a: set(b)}
for p, rel, mp in files:
    text = open(p, encoding='utf-8').read()
    i = text.find('#[cfg(test)]\nmod tests')
    if i >= 0:
        text = text[:i]
    text = '\n'.join(l for l in text.split('\n') if not l.lstrip().startswith('//'))
    is_mod = os.path.basename(rel) in ('mod.rs', 'lib.rs')
    for raw in PATH.findall(text):
        for path in expand(raw):
            target = resolve(mp, is_mod, path)
            # First place where the two module paths part: siblings there.
            for k in range(min(len(mp), len(target))):
                if mp[k] != target[k]:
                    folder = tuple(mp[:k])
                    if target[k] in children.get(folder, ()):
                        edges.setdefault(folder, {}).setdefault(mp[k], set()).add(target[k])
                    break

found = 0
for folder in sorted(edges):
    g = edges[folder]
    where = '::'.join(folder) or 'crate'
    # Tarjan's strongly connected components.
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

    sys.setrecursionlimit(10000)
    for v in list(g):
        if v not in idx:
            sc(v)
    for comp in comps:
        found += 1
        print(f'cycle in {where}: ' + ' '.join(comp))
        for a in comp:
            print('   ', a, '->', ' '.join(sorted(d for d in g.get(a, ()) if d in comp)))

levels = len(edges)
print(f'module cycles: {found} in {levels} folder levels of {root}')
sys.exit(1 if found else 0)
