#!/usr/bin/env python3
"""Cycles per update of every ekf-core filter on the Cortex-M3 (STM32F103 at 72 MHz), from
the thumbv7m `cycle-bench` ELF under Unicorn emulation and the model of `m3model.py`.

    cycle_count.py [--elf ELF] [--json OUT] [--check BASELINE] [--write-baseline BASELINE]
                   [--host-compare] [--top N]

Per filter: `ahrs_bench_select(id)` (initialisation window, not measured), then `steps` calls
of `ahrs_bench_step()`, each measured alone (from its first instruction to its return,
inclusive). Prints cycles at 0 and 2 wait states, the stack high-water of one step, the flash
of the code reachable from the filter's step, and where the EKF's cycles go. `--json` also
holds every step's cycles at 2 wait states (`cycles_2ws_steps`: on the gentle lap the three
rest-block ends are the steps over 45,000).
`--check` fails (exit 1) when the EKF's mean, median or maximum cycles at 2 wait states, on the
gentle lap or on the shaking one (`ekf-moving`), exceed the committed baseline by more than 5 %
(issue #36's goals are a median and a maximum). `--host-compare` checks that the emulated estimates are
bit-identical to the host build's: the final Euler output (`cargo run -p cycle-bench -- euler ID
STEPS`) and a digest of every step's full state — flags, quaternion, bias, Euler output and
covariance as bit patterns (`ahrs_bench_digest`; `cargo run -p cycle-bench -- digest ID STEPS`).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import m3model  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
DEFAULT_ELF = os.path.join(ROOT, "target", "thumbv7m-none-eabi", "release", "cycle-bench")
FILTERS = ["ekf", "ukf", "ssukf", "cf", "gyro", "ekf-moving"]
LABELS = {"ekf": "EKF", "ukf": "UKF", "ssukf": "SS-UKF", "cf": "CF (complementary)",
          "gyro": "gyro-only", "ekf-moving": "EKF, hand's shaking (tilt low-pass in use)"}
# The step function whose reachable code is a bench entry's flash.
STEP_FN = {"ekf-moving": "ekf"}
# The EKF entries the guard (--check) holds to the baseline, and their baseline keys.
GUARDED = {"ekf": "ekf", "ekf-moving": "ekf_moving"}
# Steps measured per filter: the EKF over the whole 400-sample lap (4 rest-detection block
# ends included); the others over enough steps for a stable mean (they have no periodic work).
STEPS = {"ekf": 400, "ukf": 16, "ssukf": 16, "cf": 100, "gyro": 100, "ekf-moving": 400}
ACCEL_USED = 1 << 8
SOURCE_CYCLES = 576_000  # the source's ~8 ms per update at 72 MHz
MHZ = 72.0
TOLERANCE = 0.05


def measure(m: m3model.Machine, name: str, steps: int, attribute: bool,
            lines: m3model.Lines | None = None) -> dict:
    fid = FILTERS.index(name)
    r = m.call("ahrs_bench_select", fid).result
    if r != 0:
        raise SystemExit(f"ahrs_bench_select({fid}) returned {r}")
    m.paint_stack()
    per_fn: dict = {} if attribute else None
    cyc0, cyc2, instr = [], [], []
    not_full = 0
    sites: dict = {}
    callees = {f.addr: m3model.demangle(f.name) for f in m.elf.funcs
               if m3model.category(m3model.demangle(f.name)) in ("soft-float",
                                                                 "libm")}
    for _ in range(steps):
        run = m.call("ahrs_bench_step", measure=True)
        if run.result == 0xFFFF_FFFF:
            raise SystemExit("ahrs_bench_step: no filter selected")
        if name != "gyro" and not run.result & ACCEL_USED:
            not_full += 1
        bc = [] if lines else None
        c = m.price(run, wait_states=2, per_function=per_fn, block_cycles=bc)
        if lines:
            m3model.call_sites(m, run, bc, callees, sites)
        cyc0.append(c.core)
        cyc2.append(c.cycles)
        instr.append(c.instructions)
        # The step's full state into the running digest (not measured; a few hundred bytes of
        # stack at most, below every step's own).
        digest = m.call("ahrs_bench_digest", run.result).result
    stack = m.stack_used()
    euler_addr = m.elf.addr_of("AHRS_BENCH_EULER")
    euler = [m.read_u32(euler_addr + 4 * i) for i in range(3)]
    funcs = m.reachable(f"ahrs_bench_step_{STEP_FN.get(name, name)}")
    flash = {}
    for f in funcs:
        cat = m3model.category(m3model.demangle(f.name))
        flash[cat] = flash.get(cat, 0) + f.size
    out = {
        "steps": steps,
        "not_full_path_steps": not_full,
        "instructions_mean": statistics.fmean(instr),
        "cycles_0ws_mean": statistics.fmean(cyc0),
        "cycles_0ws_min": min(cyc0),
        "cycles_0ws_max": max(cyc0),
        "cycles_2ws_mean": statistics.fmean(cyc2),
        "cycles_2ws_median": statistics.median(cyc2),
        "cycles_2ws_min": min(cyc2),
        "cycles_2ws_max": max(cyc2),
        "cycles_2ws_steps": cyc2,
        "stack_bytes": stack,
        "flash_bytes": sum(flash.values()),
        "flash_by_category": flash,
        "functions_reachable": len(funcs),
        "euler_bits": [f"{x:08x}" for x in euler],
        "state_digest": f"{digest:08x}",
    }
    if lines:
        by_line: dict = {}
        for (site, callee), (n, cyc) in sites.items():
            file, line = lines.at(site)
            file = file.split("/src/", 1)[-1] if "ekf-core" not in file else \
                "ekf-core/src/" + file.split("ekf-core/src/", 1)[-1]
            key = f"{file}:{line}"
            e = by_line.setdefault(key, {"calls": {}, "cycles": 0.0})
            short = callees[callee].replace("__aeabi_", "")
            e["calls"][short] = e["calls"].get(short, 0) + n / steps
            e["cycles"] += cyc / steps
        out["runtime_calls_by_line"] = sorted(
            ({"line": k, "calls_per_step": v["calls"], "cycles_2ws_per_step": v["cycles"]}
             for k, v in by_line.items()), key=lambda r: -r["cycles_2ws_per_step"])
        out["runtime_calls_per_step"] = sum(sum(r["calls"].values()) for r in by_line.values())
    if attribute:
        total = sum(v[2] for v in per_fn.values())
        rows = sorted(per_fn.items(), key=lambda kv: -kv[1][2])
        out["per_function"] = [
            {"function": k, "calls_per_step": v[0] / steps, "instructions_per_step": v[1] / steps,
             "cycles_2ws_per_step": v[2] / steps, "share": v[2] / total}
            for k, v in rows]
        cats = {}
        for k, v in per_fn.items():
            c = m3model.category(k)
            cats[c] = cats.get(c, 0) + v[2]
        out["cycles_2ws_by_category"] = {k: v / steps for k, v in cats.items()}
    return out


def host_digest(fid: int, steps: int) -> str:
    """The host build's digest of every step's full state (`ahrs_bench_digest`: flags,
    quaternion, bias, Euler output, covariance, as bit patterns)."""
    exe = os.path.join(ROOT, "target", "debug", "cycle-bench")
    cmd = [exe] if os.path.exists(exe) else ["cargo", "run", "-q", "-p", "cycle-bench", "--"]
    p = subprocess.run(cmd + ["digest", str(fid), str(steps)], cwd=ROOT, capture_output=True,
                       text=True, check=True)
    return p.stdout.strip()


def host_euler(fid: int, steps: int) -> list[str]:
    """The host build's Euler bits (target/debug/cycle-bench, built by scripts/cycle-count next
    to the thumb build so both see the same sources; else `cargo run`)."""
    exe = os.path.join(ROOT, "target", "debug", "cycle-bench")
    cmd = [exe] if os.path.exists(exe) else ["cargo", "run", "-q", "-p", "cycle-bench", "--"]
    p = subprocess.run(cmd + ["euler", str(fid), str(steps)], cwd=ROOT, capture_output=True,
                       text=True, check=True)
    return p.stdout.split()


def fmt_int(x: float) -> str:
    return f"{round(x):,}"


def report(res: dict, top: int) -> str:
    lines = []
    lines.append("| filter | instructions | cycles, 0 WS | cycles, 2 WS (mean; min–max) | µs at 72 MHz "
                 "(2 WS) | vs source's 576,000 | stack of one step | flash of its code |")
    lines.append("|---|---:|---:|---:|---:|---:|---:|---:|")
    for name in FILTERS:
        r = res["filters"][name]
        lines.append(
            f"| {LABELS[name]} | {fmt_int(r['instructions_mean'])} | {fmt_int(r['cycles_0ws_mean'])}"
            f" | {fmt_int(r['cycles_2ws_mean'])} ({fmt_int(r['cycles_2ws_min'])}–"
            f"{fmt_int(r['cycles_2ws_max'])}) | {r['cycles_2ws_mean'] / MHZ:,.0f}"
            f" | {SOURCE_CYCLES / r['cycles_2ws_mean']:,.1f}× | {r['stack_bytes']:,} B"
            f" | {r['flash_bytes']:,} B |")
    ekf = res["filters"]["ekf"]
    lines.append("")
    for name in GUARDED:
        r = res["filters"][name]
        lines.append(f"{LABELS[name]}: cycles at 2 WS per step by category: " + ", ".join(
            f"{k} {fmt_int(v)} ({v / r['cycles_2ws_mean']:.0%})"
            for k, v in sorted(r["cycles_2ws_by_category"].items(), key=lambda kv: -kv[1])))
    lines.append("")
    lines.append(f"EKF: top {top} functions (self cycles at 2 WS per step)")
    lines.append("| function | calls/step | instructions/step | cycles/step | share |")
    lines.append("|---|---:|---:|---:|---:|")
    for row in ekf["per_function"][:top]:
        lines.append(f"| `{row['function']}` | {row['calls_per_step']:.1f} | "
                     f"{fmt_int(row['instructions_per_step'])} | "
                     f"{fmt_int(row['cycles_2ws_per_step'])} | {row['share']:.1%} |")
    lines.append("")
    lines.append(f"EKF: soft-float and libm calls by source line (the innermost inlined line of the "
                 f"call; {ekf['runtime_calls_per_step']:.0f} calls per step; cycles include the "
                 f"callee, 2 WS), top {top}")
    lines.append("| line | calls/step | cycles/step |")
    lines.append("|---|---|---:|")
    for row in ekf["runtime_calls_by_line"][:top]:
        calls = ", ".join(f"{v:.1f} {k}" for k, v in sorted(row["calls_per_step"].items()))
        lines.append(f"| `{row['line']}` | {calls} | {fmt_int(row['cycles_2ws_per_step'])} |")
    lines.append("")
    lines.append("Flash of the code reachable from each filter's step (bytes): " + "; ".join(
        f"{LABELS[n]}: " + ", ".join(f"{k} {v:,}" for k, v in sorted(
            res['filters'][n]['flash_by_category'].items())) for n in FILTERS))
    return "\n".join(lines)


def softfloat(m) -> str:
    """The soft-float routines the build linked (`AHRS_BENCH_SOFTFLOAT`, NUL-terminated)."""
    raw = bytes(m.uc.mem_read(m.elf.addr_of("AHRS_BENCH_SOFTFLOAT"), 32))
    return raw.split(b"\0", 1)[0].decode()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--elf", default=DEFAULT_ELF)
    ap.add_argument("--json", help="write the full results here")
    ap.add_argument("--check", metavar="BASELINE", help="fail when the EKF is >5%% slower")
    ap.add_argument("--write-baseline", metavar="BASELINE")
    ap.add_argument("--host-compare", action="store_true",
                    help="check the emulated estimates bit for bit against the host build")
    ap.add_argument("--top", type=int, default=15)
    ap.add_argument("--filters", default=",".join(FILTERS))
    a = ap.parse_args(argv)

    t0 = time.time()
    m = m3model.Machine(a.elf)
    res = {"elf": os.path.relpath(a.elf, ROOT), "model": "m3model (docs/performance.md)",
           "softfloat": softfloat(m), "filters": {}}
    print(f"cycle-count: soft-float routines linked: {res['softfloat']} (tools/soft_float.rs)",
          file=sys.stderr)
    lines = m3model.Lines(a.elf)
    for name in a.filters.split(","):
        res["filters"][name] = measure(m, name, STEPS[name], attribute=True,
                                       lines=lines if name in GUARDED else None)
        print(f"cycle-count: {name}: {STEPS[name]} steps measured ({time.time() - t0:.0f} s)",
              file=sys.stderr)
    if set(res["filters"]) == set(FILTERS):
        print(report(res, a.top))
    else:
        print(json.dumps(res["filters"], indent=1)[:4000])

    ok = True
    for name, r in res["filters"].items():
        if r["not_full_path_steps"]:
            print(f"FAIL: {name}: {r['not_full_path_steps']} steps did not use the accelerometer",
                  file=sys.stderr)
            ok = False
    if a.host_compare:
        for name, r in res["filters"].items():
            host = host_euler(FILTERS.index(name), r["steps"])
            same = host == r["euler_bits"]
            print(f"host vs emulated estimate after {r['steps']} {name} steps: "
                  f"{'identical' if same else 'DIFFERENT'} ({' '.join(host)})")
            ok &= same
            host_d = host_digest(FILTERS.index(name), r["steps"])
            same = host_d == r["state_digest"]
            print(f"host vs emulated full state of every one of the {r['steps']} {name} steps "
                  f"(flags, quaternion, bias, Euler, covariance; bit patterns): "
                  f"{'identical' if same else 'DIFFERENT'} (digest {host_d})")
            ok &= same
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=1)
    if a.write_baseline:
        e = res["filters"]["ekf"]
        base = {
            "comment": "Committed EKF cycle figures (scripts/cycle-count --check fails above "
                       "+5 %). Regenerate with scripts/cycle-count --write-baseline after an "
                       "intended change.",
            "softfloat": res["softfloat"],
            "ekf_cycles_2ws_mean": round(e["cycles_2ws_mean"]),
            "ekf_cycles_0ws_mean": round(e["cycles_0ws_mean"]),
            "ekf_instructions_mean": round(e["instructions_mean"]),
            "ekf_cycles_2ws_median": round(e["cycles_2ws_median"]),
            "ekf_cycles_2ws_max": e["cycles_2ws_max"],
            "ekf_moving_cycles_2ws_mean": round(res["filters"]["ekf-moving"]["cycles_2ws_mean"]),
            "ekf_moving_cycles_2ws_median": round(
                res["filters"]["ekf-moving"]["cycles_2ws_median"]),
            "ekf_moving_cycles_2ws_max": res["filters"]["ekf-moving"]["cycles_2ws_max"],
            "others_cycles_2ws_mean": {n: round(r["cycles_2ws_mean"])
                                       for n, r in res["filters"].items() if n not in GUARDED},
        }
        with open(a.write_baseline, "w") as f:
            json.dump(base, f, indent=1)
            f.write("\n")
        print(f"baseline written to {a.write_baseline}")
    if a.check:
        with open(a.check) as f:
            base = json.load(f)
        e = res["filters"]["ekf"]
        if base.get("softfloat", res["softfloat"]) != res["softfloat"]:
            print(f"FAIL: the baseline was measured with {base['softfloat']}'s soft-float, this "
                  f"build links {res['softfloat']}'s (tools/soft_float.rs; on Debian: apt "
                  "install gcc-arm-none-eabi, which scripts/setup.sh does)", file=sys.stderr)
            ok = False
        checks = []
        for name, prefix in GUARDED.items():
            r = res["filters"].get(name)
            if r is None:
                continue
            checks += [(f"{prefix}_cycles_2ws_mean", r["cycles_2ws_mean"]),
                       (f"{prefix}_cycles_2ws_median", r["cycles_2ws_median"]),
                       (f"{prefix}_cycles_2ws_max", r["cycles_2ws_max"])]
        for key, now in checks:
            if key not in base:
                print(f"FAIL: {key} is not in the baseline (scripts/cycle-count "
                      "--write-baseline)", file=sys.stderr)
                ok = False
                continue
            ref = base[key]
            ratio = now / ref
            verdict = "ok" if ratio <= 1 + TOLERANCE else "FAIL"
            print(f"check {key}: {now:,.0f} against baseline {ref:,} ({ratio - 1:+.1%}, limit "
                  f"+{TOLERANCE:.0%}): {verdict}")
            if ratio > 1 + TOLERANCE:
                ok = False
            elif ratio < 1 - TOLERANCE:
                print(f"  {key} is {1 - ratio:.0%} below the baseline: commit the new figure "
                      "(scripts/cycle-count --write-baseline) so the guard keeps it")
    print(f"cycle-count: done in {time.time() - t0:.0f} s", file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
