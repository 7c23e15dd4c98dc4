"""Mutation testing of the method's core and the results file: mutmut makes small changes to the code (an operator,
a constant, a comparison) one at a time and runs the tests that cover it; a change no test notices is a survivor.

    python benchmarks/mutation.py                     # every module of [tool.mutmut] only_mutate (hours)
    python benchmarks/mutation.py app.sinks.results_file avcore.speaking   # some modules
    python benchmarks/mutation.py --report            # the table of the last run, without running

Runs outside CI (it takes hours on two cores). After changing ``only_mutate`` in pyproject.toml, delete ``mutants/``:
mutmut keeps the copies it made before, unmutated for a module that was not in the list. Prints one row a module:
mutants, killed, survived, the score (killed / tested), as docs/results.md shows it; `mutmut results` lists the
survivors, `mutmut show NAME` one of them. mutmut does not test a survivor again when tests are added:

    python benchmarks/mutation.py --retest-survivors avcore.speaking   # after adding tests for its survivors
"""
from __future__ import annotations

import argparse
import collections
import json
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


def forget_survivors(modules: list[str]) -> int:
    """Reset the recorded result of every surviving mutant of ``modules`` (their ``mutants/<path>.meta`` files), so
    that the next ``mutmut run`` tests them again against the tests as they are now."""
    reset = 0
    for module in modules:
        meta = ROOT / "mutants" / (module.replace(".", "/") + ".py.meta")
        if not meta.is_file():
            raise SystemExit(f"mutation: no mutmut record for {module} ({meta}); run it once first")
        record = json.loads(meta.read_text())
        codes = record["exit_code_by_key"]
        for name, code in codes.items():
            if code == 0:  # pytest passed with the mutant in: it survived
                codes[name] = None
                reset += 1
        meta.write_text(json.dumps(record))
    return reset


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
    parser.add_argument("--retest-survivors", action="store_true",
                        help="mark the named modules' survivors untested first, so that new tests meet them")
    args = parser.parse_args()
    if args.retest_survivors:
        if not args.modules:
            parser.error("--retest-survivors needs the modules whose survivors to test again")
        print(f"{forget_survivors(args.modules)} survivors to test again")
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
