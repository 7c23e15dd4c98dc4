"""Mutation testing of the method's core and the results file: mutmut makes small changes to the code (an operator,
a constant, a comparison) one at a time and runs the tests that cover it; a change no test notices is a survivor.

    python benchmarks/mutation.py                     # every module of [tool.mutmut] only_mutate (hours)
    python benchmarks/mutation.py app.sinks.results_file avcore.speaking   # some modules
    python benchmarks/mutation.py --report            # the table of the last run, without running

Runs outside CI (it takes hours on two cores). After changing ``only_mutate`` in pyproject.toml, delete ``mutants/``:
mutmut keeps the copies it made before, unmutated for a module that was not in the list. Prints one row a module: mutants, killed, survived, the score
(killed / tested), as docs/results.md shows it; `mutmut results` lists the survivors, `mutmut show NAME` one of them.
"""
from __future__ import annotations

import argparse
import collections
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _mutmut(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mutmut", *args], cwd=ROOT, text=True, capture_output=True)


def statuses() -> dict[str, collections.Counter]:
    """{module: Counter(status)} of every mutant of the last run (`mutmut results --all true`)."""
    done = _mutmut("results", "--all", "true")
    if done.returncode != 0:
        raise SystemExit(f"mutation: mutmut results failed: {done.stderr.strip()[-500:]}")
    out: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    for line in done.stdout.splitlines():
        name, _, status = line.strip().rpartition(": ")
        if name:
            module = name.split(".x", 1)[0].split(".xǁ", 1)[0]
            out[module][status] += 1
    return out


def table(counts: dict[str, collections.Counter]) -> str:
    rows = ["| module | mutants | killed | survived | no tests | timeout | not run yet | score |",
            "|---|---|---|---|---|---|---|---|"]
    for module in sorted(counts):
        c = counts[module]
        tested = sum(c.values()) - c["skipped"] - c["no tests"] - c["not checked"]  # a stopped run leaves some
        killed = c["killed"] + c["timeout"]
        score = f"{100 * killed / tested:.1f} %" if tested else "n/a"
        rows.append(f"| `{module}` | {sum(c.values())} | {c['killed']} | {c['survived']} | {c['no tests']} | "
                    f"{c['timeout']} | {c['not checked']} | {score} |")
    return "\n".join(rows)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("modules", nargs="*", help="dotted module names (default: every module configured)")
    parser.add_argument("--report", action="store_true", help="only print the table of the last run")
    parser.add_argument("--max-children", type=int, default=2, help="mutants tested at once (default 2)")
    args = parser.parse_args()
    if not args.report:
        names = [f"{m}.*" for m in args.modules]
        done = subprocess.run([sys.executable, "-m", "mutmut", "run", "--max-children", str(args.max_children),
                               *names], cwd=ROOT)
        if done.returncode not in (0, 1):
            return done.returncode
    counts = statuses()
    if args.modules:
        counts = {m: c for m, c in counts.items() if any(m.startswith(p) for p in args.modules)}
    print(table(counts))
    return 0


if __name__ == "__main__":
    sys.exit(main())
