#!/usr/bin/env python3
"""Proves from the target image's link map (ld -Map --cref) that nothing of the localizer reaches
the heap: no object of libv2xloc_algo.a, libv2xloc_fixture.a or the image's main refers, directly
or through the objects it pulls in (libc, libm, libstdc++), to an allocator or exception-throwing
symbol. The image's stdio (newlib rdimon's FILE buffers) does allocate: it is reached only
through semihosting_io.cpp, which is not traversed. Prints the chain that reaches one.

usage: check_target_heap.py IMAGE.map
"""
import collections
import os
import re
import sys

FORBIDDEN = re.compile(r"^(malloc|free|calloc|realloc|_malloc_r|_free_r|_calloc_r|_realloc_r|_sbrk|_sbrk_r|"
                       r"_Zn[wa][jm].*|_Zd[la]Pv.*|__cxa_allocate_exception|__cxa_throw)$")
ROOTS = re.compile(r"libv2xloc_(algo|fixture)\.a\(|/target/main\.cpp\.obj$")
# The harness's host I/O: the one object allowed to reach stdio (not traversed).
HOST_IO = re.compile(r"/semihosting_io\.cpp\.obj$")


def cref(path):
    """symbol -> (defining object, [referring objects])"""
    table, sym, lines = {}, None, open(path).read().split("Cross Reference Table", 1)[1].splitlines()
    for line in lines[1:]:
        if not line.strip() or line.startswith("Symbol"):
            continue
        if not line[0].isspace():
            parts = line.split()
            sym = parts[0]
            table[sym] = [parts[1] if len(parts) > 1 else None, []]
        elif sym is not None:
            obj = line.strip()
            if table[sym][0] is None:
                table[sym][0] = obj
            else:
                table[sym][1].append(obj)
    return table


def short(obj):
    return re.sub(r"^.*/", "", obj)


def main():
    if len(sys.argv) != 2:
        print(__doc__)
        return 2
    if not os.path.exists(sys.argv[1]):
        print(f"check_target_heap: SKIPPED: no link map {sys.argv[1]} (cmake --build --preset cortex-r52 first)")
        return 77
    table = cref(sys.argv[1])
    edges = collections.defaultdict(set)  # referring object -> (symbol, defining object)
    for sym, (definer, users) in table.items():
        for u in users:
            if definer and u != definer:
                edges[u].add((sym, definer))
    roots = {u for u in edges if ROOTS.search(u)}
    if not roots:
        print("check_target_heap: no localizer objects in the map (wrong file?)")
        return 1
    seen, queue = {r: None for r in roots}, collections.deque(roots)
    bad = []
    while queue:
        obj = queue.popleft()
        for sym, definer in sorted(edges[obj]):
            if FORBIDDEN.match(sym):
                bad.append((obj, sym))
            if definer not in seen and not HOST_IO.search(definer):
                seen[definer] = (obj, sym)
                queue.append(definer)
    if bad:
        for obj, sym in bad[:10]:
            chain, o = [f"{short(obj)} -> {sym}"], obj
            while seen[o] is not None:
                o, s = seen[o]
                chain.append(f"{short(o)} -> {s}")
            print("check_target_heap: HEAP reached: " + " <- ".join(chain))
        return 1
    print(f"check_target_heap: {len(roots)} localizer objects and the {len(seen) - len(roots)} library objects "
          f"they pull in refer to no allocator or exception symbol (malloc/free/new/delete/sbrk/__cxa_throw)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
