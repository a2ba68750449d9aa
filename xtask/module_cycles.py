#!/usr/bin/env python3
"""Lists pairs of top-level host modules that import each other (A uses crate::B, B uses crate::A),
plus longer cycles, from `crate::x` paths anywhere in non-test code."""
import os, re, sys, itertools
root = sys.argv[1] if len(sys.argv) > 1 else 'host/src'
mods = {}
for dp, dn, fn in os.walk(root):
    for f in fn:
        if not f.endswith('.rs'): continue
        p = os.path.join(dp, f); rel = os.path.relpath(p, root)
        top = rel.split(os.sep)[0].removesuffix('.rs')
        if top in ('lib', 'main'): continue
        if rel.endswith('tests.rs') or '/tests/' in rel: continue
        text = open(p).read()
        text = '\n'.join(l for l in text.split('\n') if not l.lstrip().startswith('//'))
        # drop #[cfg(test)] mod tests { ... } tails
        i = text.find('#[cfg(test)]\nmod tests')
        if i >= 0: text = text[:i]
        deps = set(re.findall(r'crate::(\w+)', text))
        # `use crate::{a, b::c}` groups
        for g in re.findall(r'crate::\{([^}]*)\}', text):
            deps |= set(re.findall(r'(?:^|,)\s*(\w+)', g))
        mods.setdefault(top, set()).update(d for d in deps if d != top)
names = set(mods)
g = {m: {d for d in ds if d in names} for m, ds in mods.items()}
pairs = sorted({tuple(sorted((a, b))) for a in g for b in g[a] if a in g.get(b, ())})
for a, b in pairs: print(f'cycle: {a} <-> {b}')
# longer cycles via SCCs
idx, low, st, on, out, c = {}, {}, [], set(), [], [0]
def sc(v):
    idx[v] = low[v] = c[0]; c[0] += 1; st.append(v); on.add(v)
    for w in g[v]:
        if w not in idx: sc(w); low[v] = min(low[v], low[w])
        elif w in on: low[v] = min(low[v], idx[w])
    if low[v] == idx[v]:
        comp = []
        while True:
            w = st.pop(); on.discard(w); comp.append(w)
            if w == v: break
        if len(comp) > 1: out.append(sorted(comp))
sys.setrecursionlimit(10000)
for v in g:
    if v not in idx: sc(v)
for comp in out:
    print('strongly connected:', ' '.join(comp))
    for a in comp:
        print('   ', a, '->', ' '.join(sorted(d for d in g[a] if d in comp)))
print(f'{len(pairs)} mutual pairs, {len(out)} cyclic groups')
