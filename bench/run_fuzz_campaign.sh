#!/usr/bin/env bash
# A longer fuzzing campaign than the test command's: deploy/fuzz.sh with SECONDS per
# target (default 120), then bench/results/fuzz_campaign.md from its libFuzzer logs: per
# target the executions, exec/s, coverage (libFuzzer's cov: edges and ft: features at
# its last stats line), corpus size, peak RSS and the crashes found, with each crash's
# input; and the reproducers kept in server/fuzz/regressions/, open and fixed.
#   bash bench/run_fuzz_campaign.sh [SECONDS]
set -uo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
seconds="${1:-120}"
bash deploy/fuzz.sh "$seconds" | tee build/fuzz-campaign.out
status=${PIPESTATUS[0]}

python3 - "$seconds" "$status" >bench/results/fuzz_campaign.md <<'PY'
import re
import subprocess
import sys
from pathlib import Path

seconds, status = int(sys.argv[1]), int(sys.argv[2])
build = Path("build/fuzz")
regressions = Path("server/fuzz/regressions")
open_list = regressions / "open.txt"
still_open = set(open_list.read_text().split()) if open_list.exists() else set()


def stat(log: str, name: str) -> str:
    found = re.findall(rf"^stat::{name}:\s*(\d+)", log, re.M)
    return found[-1] if found else "?"


def run(*command: str) -> str:
    return subprocess.run(command, capture_output=True, text=True).stdout.strip()


commit = run("git", "rev-parse", "--short", "HEAD")
dirty = " (with uncommitted changes in the tree)" if run("git", "status", "--porcelain", "--", "server") else ""
clang = run("clang++", "--version").splitlines()[0]
cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")

print("# Fuzzing campaign\n")
print(f"`bash bench/run_fuzz_campaign.sh {seconds}`: each libFuzzer target of `server/fuzz/` for {seconds} s "
      f"(`-seed=1 -rss_limit_mb=2048 -timeout=10`), from the seed corpora `server/fuzz/make_seed_corpora.py` "
      f"makes, built by `deploy/fuzz.sh` with {clang}, -O1, ASan+UBSan (`-fno-sanitize-recover=all`) and "
      f"libFuzzer's coverage. Commit {commit}{dirty}; {run('nproc')} x {cpu}, run niced beside other work. "
      f"*cov* counts the coverage edges reached, *ft* libFuzzer's features (edges with hit counts, "
      f"comparisons), both from the last stats line; *corpus* is the inputs kept and their size.\n")
print("| target | executions | exec/s | cov | ft | corpus | peak RSS | crashes found | crash input |")
print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |")
for log_path in sorted((build / "logs").glob("*.log")):
    if log_path.name.endswith(".replay.log"):
        continue
    target = log_path.stem
    log = log_path.read_text(errors="replace")
    lines = re.findall(r"^#(\d+)\s+\w+\s+cov: (\d+) ft: (\d+) corp: (\d+)/(\S+)", log, re.M)
    cov, ft, corpus = (lines[-1][1], lines[-1][2], f"{lines[-1][3]} ({lines[-1][4]})") if lines else ("?",) * 3
    artifacts = sorted(p for p in (build / "artifacts" / target).glob("*") if p.is_file())
    crashes = [p for p in artifacts if not p.name.startswith("slow-unit-")]
    inputs = ", ".join(f"`{p}`" for p in crashes) or "-"
    print(f"| {target} | {stat(log, 'number_of_executed_units')} | {stat(log, 'average_exec_per_sec')} | {cov} | "
          f"{ft} | {corpus} | {stat(log, 'peak_rss_mb')} MB | {len(crashes)} | {inputs} |")

print("\n## Reproducers kept (server/fuzz/regressions/)\n")
kept = sorted(p for p in regressions.glob("*/*") if p.is_file())
if not kept:
    print("None: no target has found a bug to keep.")
else:
    print("| target | input | state |")
    print("| --- | --- | --- |")
    for p in kept:
        name = f"{p.parent.name}/{p.name}"
        state = "open (not replayed by deploy/fuzz.sh until fixed)" if name in still_open else "fixed (replayed)"
        print(f"| {p.parent.name} | `{p.name}` | {state} |")
print(f"\ndeploy/fuzz.sh exit status: {status}.")
PY
echo "wrote bench/results/fuzz_campaign.md"
exit "$status"
