#!/usr/bin/env python3
"""Checks the target image's static RAM against its goal from the link map (ld -Map): the sizes
of the output sections .data and .bss (the localizer, the fixture player's cloud buffer and
newlib's few words; docs/target.md, "Memory"). Prints both and their sum; fails above the limit.

usage: check_target_memory.py IMAGE.map [--limit BYTES]   (default 8 MiB)
"""
import argparse
import os
import re
import sys

SECTION = re.compile(r"^\.(data|bss)\s+0x[0-9a-fA-F]+\s+0x([0-9a-fA-F]+)\s*$")


def section_sizes(path):
    """{'data': bytes, 'bss': bytes} from the map's output-section lines."""
    sizes = {}
    for line in open(path):
        m = SECTION.match(line)
        if m and m.group(1) not in sizes:
            sizes[m.group(1)] = int(m.group(2), 16)
    return sizes


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("map")
    ap.add_argument("--limit", type=int, default=8 * 1024 * 1024, help="bytes of .data + .bss allowed")
    a = ap.parse_args()
    if not os.path.exists(a.map):
        print(f"check_target_memory: SKIPPED: no link map {a.map} (cmake --build --preset cortex-r52 first)")
        return 77
    sizes = section_sizes(a.map)
    if set(sizes) != {"data", "bss"}:
        print(f"check_target_memory: FAILED: no .data / .bss output section in {a.map} (found {sorted(sizes)})")
        return 1
    total = sizes["data"] + sizes["bss"]
    print(f"check_target_memory: .data {sizes['data']:,} B + .bss {sizes['bss']:,} B = {total:,} B "
          f"({total / 1048576:.2f} MiB) of {a.limit:,} B")
    if total > a.limit:
        print(f"check_target_memory: FAILED: static RAM {total:,} B over {a.limit:,} B")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
