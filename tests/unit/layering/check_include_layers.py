#!/usr/bin/env python3
"""Fails on any include or link that points up the layers of the house.

Layers, low to high: algo < hal < firmware < host_sim < tools (docs: README.md, section "Layout",
its "Layers:" paragraph). Inside firmware: protocol < wire < app (app and baremetal are programs:
nothing outside them includes or links them). tests/ may use anything. algo/ includes only algo/, Eigen and the
C++ standard library.

usage: check_include_layers.py SOURCE_DIR      check the tree, print every violation, exit 1 if any
       check_include_layers.py --self-test     prove the checker catches each kind of violation
"""
import os
import re
import sys
import tempfile

LAYERS = ["algo", "hal", "firmware", "host_sim", "tools"]
# Sub-ranks inside firmware/ (higher may include lower). Programs sit on top and are leaves.
FIRMWARE_PARTS = {"protocol": 0, "wire": 1, "app": 2, "baremetal": 2}
FIRMWARE_PROGRAMS = {"app", "baremetal"}
SOURCE_SUFFIXES = (".hpp", ".cpp", ".h", ".cc", ".ipp")
SKIP_DIRS = {".git", "build", "node_modules", "__pycache__"}

# The C++ standard headers algo/ may use: no I/O (<cstdio>, streams), no exceptions, no threads.
STD_HEADERS = set("""
algorithm any array atomic bit bitset cassert cctype cerrno cfloat charconv chrono cinttypes climits
cmath compare complex concepts cstdarg cstddef cstdint cstdlib cstring ctime deque functional initializer_list iterator limits memory new numbers numeric optional ratio
source_location span string_view tuple type_traits utility variant version
""".split())

INCLUDE_RE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]', re.M)
ADD_LIBRARY_RE = re.compile(r"add_(?:library|executable)\(\s*([\w.-]+)")
LINK_RE = re.compile(r"target_link_libraries\(\s*([\w.-]+)([^)]*)\)", re.S)


def rank_of_path(rel):
    """(layer, firmware part) of a repository path, or None outside the layered folders."""
    parts = rel.replace(os.sep, "/").split("/")
    if parts[0] not in LAYERS:
        return None
    layer = LAYERS.index(parts[0])
    sub = FIRMWARE_PARTS.get(parts[1], 0) if parts[0] == "firmware" and len(parts) > 1 else 0
    return layer, sub


def rank_of_include(target):
    if target.startswith("v2xloc/algo/"):
        return (0, 0), None
    parts = target.split("/")
    if len(parts) < 2 or parts[0] not in LAYERS:
        return None, None  # relative to the including file, or a library header
    rank = rank_of_path(target)
    program = parts[1] if parts[0] == "firmware" and parts[1] in FIRMWARE_PROGRAMS else None
    return rank, program


def same_program(rel, program):
    return rel.replace(os.sep, "/").startswith("firmware/" + program + "/")


def walk(root):
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = sorted(d for d in dirnames if d not in SKIP_DIRS and not d.startswith("build"))
        for name in sorted(filenames):
            yield os.path.relpath(os.path.join(dirpath, name), root)


def check_includes(root, rel, text, problems):
    own = rank_of_path(rel)
    if own is None:
        return
    for kind, target in INCLUDE_RE.findall(text):
        if own[0] == 0:  # algo: only algo, Eigen and the standard library
            ok = (kind == '"' and (target.startswith("v2xloc/algo/") or "/" not in target)) or \
                 (kind == "<" and (target.startswith("Eigen/") or target in STD_HEADERS))
            if not ok:
                shown = f"<{target}>" if kind == "<" else f'"{target}"'
                problems.append(f"{rel}: algo/ includes {shown}: only algo/, Eigen and the C++ standard library")
            continue
        if kind != '"':
            continue
        rank, program = rank_of_include(target)
        if rank is None:
            continue
        if rank > own:
            problems.append(f"{rel}: includes {target}, a higher layer ({LAYERS[rank[0]]})")
        elif program is not None and not same_program(rel, program):
            problems.append(f"{rel}: includes {target}: firmware/{program} is a program, only tests may use it")


def library_ranks(root, files):
    ranks = {}
    for rel in files:
        if os.path.basename(rel) != "CMakeLists.txt":
            continue
        rank = rank_of_path(rel)
        if rank is None:
            continue
        program = rel.replace(os.sep, "/").split("/")[1] if rel.startswith("firmware" + os.sep) else None
        with open(os.path.join(root, rel), encoding="utf-8") as f:
            for name in ADD_LIBRARY_RE.findall(f.read()):
                ranks[name] = (rank, os.path.dirname(rel), program if program in FIRMWARE_PROGRAMS else None)
    return ranks


def check_links(root, files, problems):
    ranks = library_ranks(root, files)
    for rel in files:
        if os.path.basename(rel) != "CMakeLists.txt" or rank_of_path(rel) is None:
            continue
        with open(os.path.join(root, rel), encoding="utf-8") as f:
            text = re.sub(r"#[^\n]*", "", f.read())
        for target, libs in LINK_RE.findall(text):
            own = ranks.get(target, (rank_of_path(rel), os.path.dirname(rel), None))
            for lib in libs.split():
                if lib not in ranks:
                    continue
                rank, folder, program = ranks[lib]
                if rank > own[0]:
                    problems.append(f"{rel}: {target} links {lib}, a higher layer ({folder})")
                elif program is not None and own[2] != program:
                    problems.append(f"{rel}: {target} links {lib}: firmware/{program} is a program, only tests may link it")


def check_tree(root):
    files = list(walk(root))
    problems = []
    for rel in files:
        if rel.endswith(SOURCE_SUFFIXES):
            with open(os.path.join(root, rel), encoding="utf-8", errors="replace") as f:
                check_includes(root, rel, f.read(), problems)
    check_links(root, files, problems)
    return files, problems


def self_test():
    """Each planted violation must be reported, and the clean files must not be."""
    tree = {
        "algo/src/a.cpp": '#include "v2xloc/algo/core/x.hpp"\n#include <cmath>\n#include <Eigen/Core>\n',
        "algo/src/bad_io.cpp": "#include <cstdio>\n#include <fstream>\n",
        "algo/src/bad_up.cpp": '#include "hal/can_frame.hpp"\n',
        "hal/ok.cpp": '#include "v2xloc/algo/core/x.hpp"\n#include <sys/socket.h>\n',
        "hal/bad.cpp": '#include "firmware/protocol/can_messages.hpp"\n',
        "firmware/wire/bad.cpp": '#include "firmware/app/localizer_port.hpp"\n',
        "firmware/app/ok.cpp": '#include "firmware/wire/input_decoder.hpp"\n#include "firmware/app/x.hpp"\n',
        "host_sim/bad.cpp": '#include "firmware/app/firmware_app.hpp"\n#include "tools/eval/metrics.hpp"\n',
        "tools/ok.cpp": '#include "host_sim/replay/event_stream.hpp"\n#include "firmware/wire/pose_frames.hpp"\n',
        "tests/ok.cpp": '#include "tools/eval/metrics.hpp"\n#include "firmware/app/firmware_app.hpp"\n',
        "firmware/app/CMakeLists.txt": "add_library(fw_app STATIC a.cpp)\ntarget_link_libraries(fw_app PUBLIC fw_wire)\n",
        "firmware/wire/CMakeLists.txt": "add_library(fw_wire STATIC a.cpp)\n",
        "host_sim/CMakeLists.txt": "add_library(sim STATIC a.cpp)\ntarget_link_libraries(sim PUBLIC fw_app fw_wire)\n",
        "hal/CMakeLists.txt": "add_library(hal STATIC a.cpp)\ntarget_link_libraries(hal PUBLIC sim)\n",
    }
    expected = [
        "algo/src/bad_io.cpp: algo/ includes <cstdio>",
        "algo/src/bad_io.cpp: algo/ includes <fstream>",
        "algo/src/bad_up.cpp: algo/ includes \"hal/can_frame.hpp\"",
        "hal/bad.cpp: includes firmware/protocol/can_messages.hpp, a higher layer",
        "firmware/wire/bad.cpp: includes firmware/app/localizer_port.hpp, a higher layer",
        "host_sim/bad.cpp: includes firmware/app/firmware_app.hpp: firmware/app is a program",
        "host_sim/bad.cpp: includes tools/eval/metrics.hpp, a higher layer",
        "host_sim/CMakeLists.txt: sim links fw_app: firmware/app is a program",
        "hal/CMakeLists.txt: hal links sim, a higher layer",
    ]
    with tempfile.TemporaryDirectory() as root:
        for rel, text in tree.items():
            os.makedirs(os.path.join(root, os.path.dirname(rel)), exist_ok=True)
            with open(os.path.join(root, rel), "w", encoding="utf-8") as f:
                f.write(text)
        _, problems = check_tree(root)
    missing = [e for e in expected if not any(p.startswith(e) for p in problems)]
    unexpected = [p for p in problems if not any(p.startswith(e) for e in expected)]
    for m in missing:
        print("self-test: not reported:", m)
    for u in unexpected:
        print("self-test: false report:", u)
    print(f"self-test: {len(problems)} planted violations reported, {len(missing)} missed, {len(unexpected)} false")
    return 1 if missing or unexpected else 0


def main(argv):
    if len(argv) == 2 and argv[1] == "--self-test":
        return self_test()
    if len(argv) != 2:
        print(__doc__)
        return 2
    files, problems = check_tree(argv[1])
    for p in problems:
        print(p)
    sources = sum(1 for f in files if f.endswith(SOURCE_SUFFIXES))
    print(f"checked {sources} sources and their CMake links: {len(problems)} arrow(s) pointing up")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
