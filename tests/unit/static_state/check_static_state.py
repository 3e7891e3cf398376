#!/usr/bin/env python3
"""Fails when algo/ keeps state outside its objects: a variable with static storage that can change.

Every stage owns its state (algo/README.md), so two localizers in one image are independent. The
check reads the compiled library's symbol tables (objdump -t): any symbol in a writable data
section (.data, .bss, their thread-local and small-data forms, common symbols) is a mutable
namespace-scope, class-static or function-local static variable, or the guard of one, whatever
the source spelled. Constants (constexpr, const with a constant initializer) live in .rodata and
pass; .data.rel.ro is read-only after relocation and passes too.

usage: check_static_state.py --objdump OBJDUMP LIBRARY...     print every such symbol, exit 1 if any
       check_static_state.py --objdump OBJDUMP --self-test PLANTED_LIBRARY
                                   prove it reports each planted kind (planted_state.cpp) and
                                   none of the planted constants
"""
import argparse
import re
import subprocess
import sys

WRITABLE = (".data", ".bss", ".tdata", ".tbss", ".sdata", ".sbss")
SYMBOL_RE = re.compile(r"^([0-9a-fA-F]+) (.{7}) (\S+)\t([0-9a-fA-F]+) (.*)$")
OBJECT_RE = re.compile(r"^(\S+):\s+file format ")

# planted_state.cpp: what the self-test expects reported (substrings of demangled names) ...
PLANTED = ["planted::g_counter", "planted::g_table", "planted::(anonymous namespace)::g_hidden",
           "planted::Holder::shared", "planted::bump()::calls", "planted::g_per_thread",
           "planted::lazy(unsigned int)::value", "guard variable for planted::lazy(unsigned int)::value"]
# ... and what it must not report.
PLANTED_CONSTANTS = ["kConstTable", "kConstexprTable", "kLocalConstant"]


def writable(section):
    if section == "*COM*":
        return True
    if ".rel.ro" in section:
        return False
    return any(section == s or section.startswith(s + ".") for s in WRITABLE)


def mutable_symbols(objdump, library):
    """(object file, section, demangled name) of every symbol in a writable section."""
    out = subprocess.run([objdump, "-t", "-C", library], check=True, capture_output=True, text=True).stdout
    found, obj = [], library
    for line in out.splitlines():
        m = OBJECT_RE.match(line)
        if m:
            obj = m.group(1)
            continue
        m = SYMBOL_RE.match(line)
        if not m:
            continue
        flags, section, name = m.group(2), m.group(3), m.group(5)
        if flags[5] == "d" or flags[6] == "f":  # section and file symbols
            continue
        if writable(section):
            found.append((obj, section, name))
    return found


def check(objdump, libraries):
    found = [s for lib in libraries for s in mutable_symbols(objdump, lib)]
    for obj, section, name in found:
        print(f"{obj}: {name} ({section}): mutable static storage; keep it in the object that uses it")
    if found:
        print(f"{len(found)} variable(s) with mutable static storage in {' '.join(libraries)}")
        return 1
    print(f"no mutable static storage in {' '.join(libraries)}")
    return 0


def self_test(objdump, planted):
    names = [name for _, _, name in mutable_symbols(objdump, planted)]
    missed = [p for p in PLANTED if not any(p in n for n in names)]
    wrong = [c for c in PLANTED_CONSTANTS if any(c in n for n in names)]
    for p in missed:
        print(f"self-test: planted {p} not reported")
    for c in wrong:
        print(f"self-test: constant {c} reported")
    if missed or wrong or check(objdump, [planted]) != 1:
        return 1
    print(f"self-test: all {len(PLANTED)} planted kinds reported, no constant")
    return 0


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--objdump", required=True)
    parser.add_argument("--self-test", action="store_true")
    parser.add_argument("libraries", nargs="+")
    args = parser.parse_args()
    if args.self_test:
        return self_test(args.objdump, args.libraries[0])
    return check(args.objdump, args.libraries)


if __name__ == "__main__":
    sys.exit(main())
