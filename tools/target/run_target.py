#!/usr/bin/env python3
"""One `target` test: the whole localizer as Cortex-R52 code under QEMU against the host's bits.

In a working folder of its own: (1) the inputs: a short recording made by v2xloc-sim and turned
into a fixture by `v2xloc-fixture record` (the offline wire path's localizer calls), or the
worst-case suite's adversarial drive (WorstCase.AdversarialPeriods with V2XLOC_TARGET_FIXTURE);
(2) the host reference: `v2xloc-fixture play` in this EMBEDDED build, checked against the
committed golden file (--golden); (3) the target run: `qemu-system-arm -M virt -cpu max -icount
shift=0` with semihosting, under a timeout. Fails unless the host reference equals the golden,
QEMU exits 0, every period's line equals the host's bit for bit (and, for a recording, the
recording run's own lines), every period's per-stage counts sum to its total, and every period
outside "setup" retires <= --budget instructions.
Exit 77 (ctest: skipped, with the reason) without qemu-system-arm or the target image, after the
golden check.

Goldens: --update-golden (or V2XLOC_UPDATE_GOLDEN=1 in the environment, e.g.
`V2XLOC_UPDATE_GOLDEN=1 ctest --preset target`) writes the host reference as the golden instead
of comparing with it; the rest of the run is unchanged.
"""
import argparse
import os
import shutil
import statistics
import subprocess
import sys

QEMU = ["qemu-system-arm", "-M", "virt", "-cpu", "max", "-m", "128M", "-nographic", "-monitor", "none",
        "-serial", "none", "-nic", "none", "-icount", "shift=0"]
REGENERATE = "V2XLOC_UPDATE_GOLDEN=1 ctest --preset target"
HOW_TO_UPDATE = f"{REGENERATE} (all goldens), or this command with --update-golden (this one)"


def run(cmd, cwd, timeout, log):
    with open(log, "w") as f:
        try:
            return subprocess.run(cmd, cwd=cwd, stdout=f, stderr=subprocess.STDOUT, timeout=timeout).returncode
        except subprocess.TimeoutExpired:
            print(f"run_target: TIMEOUT after {timeout} s: {' '.join(cmd)}")
            return None


def need(ok, what, log=None):
    if ok:
        return
    print(f"run_target: FAILED: {what}")
    if log and os.path.exists(log):
        print(open(log).read()[-4000:])
    sys.exit(1)


def pose_part(line):
    """A period line without the target's counts: what must equal the host's."""
    return line.split(" instr ")[0]


def make_inputs(a, wd, fixture, recorded):
    """The fixture: the worst-case drive's, or a (generated) recording's through `v2xloc-fixture record`."""
    if a.worst_case:
        env = dict(os.environ, V2XLOC_TARGET_FIXTURE=fixture)
        log = os.path.join(wd, "worst_case.log")
        with open(log, "w") as f:
            rc = subprocess.run([a.worst_case, "--gtest_filter=WorstCase.AdversarialPeriods"], cwd=wd, env=env,
                                stdout=f, stderr=subprocess.STDOUT, timeout=1200).returncode
        need(rc == 0, "the worst-case drive that writes the fixture", log)
        return
    rec = os.path.abspath(a.recording) if a.recording else "rec"
    if not a.recording:
        need(a.sim and a.generate, "--sim and --generate, --recording, or --worst-case")
        log = os.path.join(wd, "generate.log")
        need(run([a.sim, "generate", *a.generate, "--out", "rec"], wd, 900, log) == 0, "v2xloc-sim generate", log)
    log = os.path.join(wd, "record.log")
    need(run([a.fixture_tool, "record", rec, fixture, "--label", a.name, "--outputs", recorded], wd, 900, log) == 0,
         "v2xloc-fixture record", log)
    print(open(log).read().strip())


def golden_lines(path):
    return [l for l in open(path).read().splitlines() if l and not l.startswith("#")]


def write_golden(path, name, host_lines):
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w") as f:
        f.write(f"# Target.{name}: the host EMBEDDED build's period lines, the bits the target's must equal\n"
                f"# (docs/target.md). Regenerate: {REGENERATE}\n")
        f.write("\n".join(host_lines) + "\n")
    print(f"run_target: golden written: {path} ({len(host_lines)} periods)")


def golden_mismatch(path, host_lines):
    """None if the host reference equals the committed golden, else what differs first."""
    if not os.path.exists(path):
        return f"no golden file {path}; create it with {HOW_TO_UPDATE}"
    gold = golden_lines(path)
    first = next((i for i, (g, h) in enumerate(zip(gold, host_lines)) if g != h), None)
    if first is None and len(gold) == len(host_lines):
        return None
    if first is None:
        return (f"the host reference has {len(host_lines)} periods, the golden {path} {len(gold)}; if the change "
                f"is intended, regenerate: {HOW_TO_UPDATE}")
    differing = sum(g != h for g, h in zip(gold, host_lines))
    return (f"the host reference differs from the golden {path} first at period {first} ({differing} of "
            f"{min(len(gold), len(host_lines))} periods differ)\n  golden {gold[first]}\n  host   {host_lines[first]}\n"
            f"  if the change of behaviour is intended, regenerate: {HOW_TO_UPDATE}")


def check_golden(a, host_lines):
    """Writes or compares the golden; the mismatch text (None when it matches or there is no --golden)."""
    if not a.golden:
        return None
    if a.update_golden:
        write_golden(a.golden, a.name, host_lines)
        return None
    mismatch = golden_mismatch(a.golden, host_lines)
    print(f"run_target: GOLDEN MISMATCH: {mismatch}" if mismatch else f"run_target: golden matches: {a.golden}")
    return mismatch


def run_qemu(a, wd):
    log = os.path.join(wd, "qemu.log")
    image = os.path.abspath(a.image)
    cmd = QEMU + ["-semihosting-config", f"enable=on,target=native,arg={image},arg=inputs.fix,arg=target.txt",
                  "-kernel", image]
    rc = run(cmd, wd, a.timeout, log)
    need(rc == 0, f"the target run (QEMU exit status {rc})", log)


def compare(a, host_lines, target, recorded):
    """The target's period lines (the '#' summary apart) after checking them against the host's."""
    lines = open(target).read().splitlines()
    periods = [l for l in lines if not l.startswith("#")]
    need(len(periods) == len(host_lines), f"{len(periods)} target periods, {len(host_lines)} host periods")
    diff = [(h, t) for h, t in zip(host_lines, periods) if pose_part(t) != h]
    for h, t in diff[:5]:
        print(f"  host   {h}\n  target {pose_part(t)}")
    need(not diff, f"{len(diff)} of {len(periods)} periods differ from the host's bits")
    if not a.worst_case:
        rec = open(recorded).read().splitlines()
        need(rec == host_lines, "the fixture's host play differs from the recording's own run")
    return periods, [l for l in lines if l.startswith("#")]


def print_stages(periods):
    """The target's instructions over the run by bucket (firmware/fixture/period_buckets.hpp), largest first."""
    totals = {}
    for l in periods:
        f = l.split()
        pairs = f[f.index("stages") + 1:]
        for name, n in zip(pairs[0::2], pairs[1::2]):
            totals[name] = totals.get(name, 0) + int(n)
    whole = sum(totals.values())
    top = sorted(totals.items(), key=lambda kv: -kv[1])
    print("  by stage: " + ", ".join(f"{name} {100.0 * n / whole:.1f} %" for name, n in top if n * 1000 >= whole))


def check_budget(a, periods, summary):
    counted = []
    for l in periods:
        f = l.split()
        instr, cycles = int(f[f.index("instr") + 1]), int(f[f.index("cycles") + 1])
        need("stages" in f, f"period {f[0]}: no per-stage counts in the target's line")
        buckets = f[f.index("stages") + 1:]
        need(sum(int(n) for n in buckets[1::2]) == instr, f"period {f[0]}: the stages do not sum to instr {instr}")
        counted.append((f[1], int(f[0]), instr, cycles))
    inside = [c for c in counted if c[0] != "setup"]
    over = [c for c in inside if c[2] > a.budget]
    instr = [c[2] for c in inside]
    cycles = [c[3] for c in inside]
    print(f"run_target: {a.name}: {len(periods)} periods bit-identical to the host EMBEDDED build; "
          f"{len(inside)} counted: instructions median {statistics.median(instr) / 1e6:.1f} M, "
          f"p99 {sorted(instr)[min(len(instr) - 1, (99 * len(instr)) // 100)] / 1e6:.1f} M, "
          f"max {max(instr) / 1e6:.1f} M (period {max(inside, key=lambda c: c[2])[1]}), "
          f"cycles median {statistics.median(cycles) / 1e6:.1f} M max {max(cycles) / 1e6:.1f} M; "
          + "; ".join(s[2:] for s in summary))
    print_stages(periods)
    if a.worst_case:
        cases = {}
        for c in inside:
            cases[c[0]] = max(cases.get(c[0], 0), c[2])
        for name, worst in cases.items():
            print(f"  {name:28s} max {worst / 1e6:7.1f} M")
    setup = [c for c in counted if c[0] == "setup"]
    if setup:
        print(f"  setup periods (not budgeted): {len(setup)}, max {max(c[2] for c in setup) / 1e6:.1f} M")
    for c in over[:10]:
        print(f"  over the budget: {c[0]} period {c[1]}: {c[2] / 1e6:.1f} M")
    if over and a.known_over > 0:
        print(f"run_target: KNOWN GAP, NOT MET: {len(over)} of {len(inside)} periods over {a.budget / 1e6:.0f} M "
              f"(max {max(instr) / 1e6:.1f} M); failing only above the ceiling {a.known_over / 1e6:.0f} M")
        over = [c for c in over if c[2] > a.known_over]
    need(not over, f"{len(over)} periods over {max(a.budget, a.known_over) / 1e6:.0f} M instructions")


def check_stack(a, summary):
    """The painted stack's high-water mark the image reports ('# stack_high_water N painted P')."""
    marks = [s.split() for s in summary if s.startswith("# stack_high_water")]
    need(len(marks) == 1 and len(marks[0]) >= 3, "no stack high-water line in the target's output")
    used, painted = int(marks[0][2]), int(marks[0][4]) if len(marks[0]) >= 5 else 0
    need(used < painted, f"the stack reached the end of its painted {painted} B: the mark is a floor, not a measure")
    need(used <= a.max_stack, f"stack high-water {used} B over {a.max_stack} B")


def parse_args():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--name", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--image", required=True, help="v2xloc_target.elf (cortex-r52 preset)")
    ap.add_argument("--fixture-tool", required=True, help="v2xloc-fixture of this EMBEDDED build")
    ap.add_argument("--sim", help="v2xloc-sim: make the recording with it")
    ap.add_argument("--generate", nargs=argparse.REMAINDER, default=[],
                    help="v2xloc-sim generate arguments (last option)")
    ap.add_argument("--recording", help="an existing recording folder instead of --sim/--generate")
    ap.add_argument("--worst-case", help="test_worst_case_localizer: its adversarial drive is the fixture")
    ap.add_argument("--budget", type=float, default=100e6, help="instructions per period outside 'setup'")
    ap.add_argument("--max-stack", type=int, default=64 * 1024,
                    help="bytes of stack the run may reach (the painted high-water mark; docs/target.md)")
    ap.add_argument("--timeout", type=int, default=900, help="seconds for the QEMU run")
    ap.add_argument("--golden", help="the committed host lines the host reference must equal")
    ap.add_argument("--update-golden", action="store_true",
                    default=os.environ.get("V2XLOC_UPDATE_GOLDEN", "") not in ("", "0"),
                    help="write the host reference to --golden instead of comparing (env V2XLOC_UPDATE_GOLDEN=1)")
    ap.add_argument("--known-over", type=float, default=0.0,
                    help="a known gap (docs/target.md): periods over --budget pass up to this ceiling, reported")
    a = ap.parse_args()
    for tool in ("fixture_tool", "sim", "worst_case"):  # the steps run in the working folder
        if getattr(a, tool):
            setattr(a, tool, os.path.abspath(getattr(a, tool)))
    return a


def main():
    a = parse_args()
    wd = os.path.abspath(a.workdir)
    shutil.rmtree(wd, ignore_errors=True)
    os.makedirs(wd)
    fixture, host, target, recorded = (os.path.join(wd, n) for n in ("inputs.fix", "host.txt", "target.txt", "recorded.txt"))
    make_inputs(a, wd, fixture, recorded)
    log = os.path.join(wd, "play.log")
    need(run([a.fixture_tool, "play", fixture, host], wd, 900, log) == 0, "v2xloc-fixture play (host reference)", log)
    host_lines = open(host).read().splitlines()
    need(len(host_lines) > 0, "no periods in the host reference")
    mismatch = check_golden(a, host_lines)

    skip = None
    if shutil.which("qemu-system-arm") is None:
        skip = "qemu-system-arm not installed (apt-get install qemu-system-arm)"
    elif not os.path.exists(a.image):
        skip = f"no target image {a.image} (cmake --build --preset cortex-r52 first)"
    if skip and not mismatch:
        print(f"run_target: SKIPPED the target run: {skip}")
        return 77
    if not skip:
        run_qemu(a, wd)
        periods, summary = compare(a, host_lines, target, recorded)
    need(not mismatch, "the golden check (above)")
    check_budget(a, periods, summary)
    check_stack(a, summary)
    return 0


if __name__ == "__main__":
    sys.exit(main())
