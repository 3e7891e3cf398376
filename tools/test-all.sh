#!/usr/bin/env bash
# The whole test suite, as CI runs it: host build + tests, ASan/UBSan tests, the EMBEDDED profile's
# tests, aarch64 cross build + tests under qemu-aarch64, the bare-metal Cortex-R52 build with its
# link check and the whole localizer run as R52 code under QEMU (ctest label target), the installed
# package's consumers and the fuzz targets.
set -euo pipefail
cd "$(dirname "$0")/.."
JOBS=${JOBS:-$(nproc)}
# One compiler cache for every tree of this checkout (presets and the install tests' cross trees).
export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=1

step() { printf '\n==== %s ====\n' "$*"; }

step "host: build + tests"
cmake --preset host >/dev/null
cmake --build --preset host -j "$JOBS"
ctest --preset host

step "host-asan: build + tests (ASan + UBSan)"
cmake --preset host-asan >/dev/null
cmake --build --preset host-asan -j "$JOBS"
ctest --preset host-asan

step "host-embedded: the EMBEDDED profile (the target's capacities): build + tests"
cmake --preset host-embedded >/dev/null
cmake --build --preset host-embedded -j "$JOBS"
# The target runs' host tools (fixture writer, simulator), used in the cortex-r52 step.
cmake --build --preset host-embedded -j "$JOBS" --target v2xloc-sim v2xloc-fixture
ctest --preset host-embedded

step "aarch64-linux: cross build + tests under qemu-aarch64"
cmake --preset aarch64-linux >/dev/null
cmake --build --preset aarch64-linux -j "$JOBS"
ctest --preset aarch64-linux

step "cortex-r52: bare-metal build + link check + the localizer on the target under QEMU"
cmake --preset cortex-r52 >/dev/null
cmake --build --preset cortex-r52 -j "$JOBS"
tools/check-baremetal.sh build/cortex-r52/bin/v2xloc_baremetal.elf
# host-embedded's tools write the fixtures and the host reference (docs/target.md).
ctest --preset target

step "install: find_package(v2xloc) consumers for host, aarch64 (qemu) and Cortex-R52 (link)"
ctest --test-dir build/host -L install --output-on-failure

step "fuzz: a libFuzzer target per parser (clang-14, ASan + UBSan), time-limited runs"
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz -j "$JOBS"
ctest --preset fuzz

step "all test stages passed"
