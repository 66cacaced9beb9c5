#!/usr/bin/env python3
"""Import circles between the module files of each crate: edges A -> B when A names an item of
B (use crate::..., super::..., or a crate::/super:: path in code); names re-exported by a mod.rs
(pub use child::X) resolve to the child. Prints the strongly connected components of size > 1."""
import os, re, sys
root = sys.argv[1] if len(sys.argv) > 1 else '.'
crates = {'core': 'avatar_core', 'neural': 'avatar_neural', 'app': 'avatar_studio'}

def strip_tests(src):
    # drop #[cfg(test)] mod ... { } blocks (balanced braces)
    out = []; i = 0
    while True:
        m = re.search(r'#\[cfg\(test\)\]\s*mod\s+\w+\s*\{', src[i:])
        if not m: out.append(src[i:]); break
        out.append(src[i:i+m.start()])
        j = i + m.end(); depth = 1
        while depth and j < len(src):
            if src[j] == '{': depth += 1
            elif src[j] == '}': depth -= 1
            j += 1
        i = j
    s = ''.join(out)
    s = re.sub(r'//[^\n]*', '', s)
    return s

total = 0
for crate in crates:
    src_dir = os.path.join(root, crate, 'src')
    files = {}
    for d, _, fs in os.walk(src_dir):
        for f in fs:
            if f.endswith('.rs'):
                p = os.path.join(d, f)
                rel = os.path.relpath(p, src_dir)[:-3].split(os.sep)
                if rel[-1] in ('mod', 'lib', 'main'): rel = rel[:-1]
                files[tuple(rel)] = p
    texts = {m: strip_tests(open(p).read()) for m, p in files.items()}
    # re-exports of mod files: name -> child module
    reexp = {}
    for m, t in texts.items():
        for g in re.finditer(r'pub\s+use\s+(?:self::)?(\w+)::\{?([^;]*);', t):
            child = m + (g.group(1),)
            if child in files:
                for name in re.findall(r'\w+', g.group(2)):
                    reexp[(m, name)] = child
    def resolve(m, parts):
        # longest prefix that is a module file, then follow re-exports
        best = None
        for k in range(len(parts), -1, -1):
            if tuple(parts[:k]) in files:
                best = tuple(parts[:k]); rest = parts[k:]; break
        if best is None: return None
        while rest and (best, rest[0]) in reexp:
            best = reexp[(best, rest[0])]; rest = rest[1:]
        return best
    def expand(prefix, body):
        # expand a use tree "a::{b, c::d}" into paths
        body = body.strip()
        m = re.match(r'^([\w:]*?)(::)?\{(.*)\}$', body, re.S)
        if m and m.group(3) is not None and body.endswith('}'):
            head = [x for x in m.group(1).split('::') if x]
            inner = m.group(3); parts = []; depth = 0; cur = ''
            for ch in inner:
                if ch == '{': depth += 1
                if ch == '}': depth -= 1
                if ch == ',' and depth == 0: parts.append(cur); cur = ''
                else: cur += ch
            parts.append(cur)
            res = []
            for p in parts:
                if p.strip(): res += expand(prefix + head, p)
            return res
        return [prefix + [x for x in re.split(r'::', body.split(' as ')[0]) if x]]
    edges = {m: set() for m in files}
    for m, t in texts.items():
        paths = []
        for u in re.finditer(r'\buse\s+([^;]+);', t):
            tree = u.group(1).strip()
            paths += expand([], tree)
        for p in re.finditer(r'\b((?:crate|super)(?:::\w+)+)', t):
            paths.append(p.group(1).split('::'))
        here = m
        for p in paths:
            if not p: continue
            if p[0] == 'crate': target = list(p[1:])
            elif p[0] in ('super', 'self'):
                base = list(here); q = list(p)
                while q and q[0] in ('super', 'self'):
                    if q[0] == 'super': base = base[:-1]
                    q = q[1:]
                target = base + q
            else: continue
            r = resolve(m, target)
            if r is not None and r != m and r != ():
                # a parent declaring/re-exporting its children is not an import
                if len(r) == len(m) + 1 and r[:len(m)] == m and files[m].endswith('mod.rs'):
                    continue
                edges[m].add(r)
    # Tarjan
    index = {}; low = {}; st = []; on = set(); sccs = []; c = [0]
    sys.setrecursionlimit(10000)
    def sc(v):
        index[v] = low[v] = c[0]; c[0] += 1; st.append(v); on.add(v)
        for w in edges[v]:
            if w not in index: sc(w); low[v] = min(low[v], low[w])
            elif w in on: low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = st.pop(); on.discard(w); comp.append(w)
                if w == v: break
            if len(comp) > 1: sccs.append(comp)
    for v in files:
        if v not in index: sc(v)
    for comp in sccs:
        names = sorted('/'.join(x) or 'lib' for x in comp)
        inner = [(a, b) for a in comp for b in edges[a] if b in comp]
        print(f'{crate}: circle of {len(comp)}: ' + ', '.join(names))
        for a, b in inner: print(f'    {"/".join(a)} -> {"/".join(b)}')
    total += len(sccs)
print(f'import circles: {total}')
