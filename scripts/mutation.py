"""Mutation testing of chosen modules with mutmut, each against only its own test folders.

Run it through ``scripts/mutation.sh`` (which installs mutmut and runs this at the lowest CPU
priority). Each module gets its own scratch copy of the project (``--work``), so modules run in
parallel without sharing mutmut's ``mutants/`` folder, and mutmut's settings come from
``[tool.mutmut]`` in pyproject.toml plus, per module, the module (``only_mutate``) and its test
folders (``pytest_add_cli_args_test_selection``). Test folders mirror the package:
``xgo_show/wire/xgo.py`` runs ``tests/wire``, unless ``[tool.xgo-show.mutation.tests]`` names
the module's tests.

Surviving mutants whose change nothing can observe are listed, with the reason, in
``scripts/mutation-equivalent.txt``; they are left out of the kill rate. The summary prints one
row a module and every other survivor's diff.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import json
import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import tomllib

ROOT = Path(__file__).resolve().parent.parent
EQUIVALENT_FILE = ROOT / "scripts" / "mutation-equivalent.txt"
# mutmut's exit-code statuses that count as caught.
CAUGHT = {"killed", "timeout", "segfault", "caught by type check"}


@dataclass
class Outcome:
    """What one module's run found."""

    module: str
    seconds: float = 0.0
    counts: dict[str, int] = field(default_factory=dict)
    survivors: list[tuple[str, str]] = field(default_factory=list)  # (name, diff)
    equivalent: list[tuple[str, str]] = field(default_factory=list)  # (name, reason)
    error: str = ""

    @property
    def total(self) -> int:
        return sum(self.counts.values())

    @property
    def caught(self) -> int:
        return sum(n for status, n in self.counts.items() if status in CAUGHT)

    @property
    def rate(self) -> float:
        """Kill rate over the mutants that are not equivalent."""
        relevant = self.total - len(self.equivalent)
        return 100.0 * self.caught / relevant if relevant else 100.0


def _toml_value(value: object) -> str:
    # JSON strings, numbers, booleans and lists of them are valid TOML values.
    return json.dumps(value)


def _settings() -> tuple[dict[str, object], dict[str, object]]:
    data = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    tool = data.get("tool", {})
    return dict(tool.get("mutmut", {})), dict(tool.get("xgo-show", {}).get("mutation", {}))


def test_folders(module: str, named: dict[str, list[str]]) -> list[str]:
    """``xgo_show/pkg/mod.py`` -> ``tests/pkg``, unless the module's tests are named in the
    configuration (folders, files or pytest options)."""
    if module in named:
        return named[module]
    parts = Path(module).parts
    return [f"tests/{parts[1]}" if len(parts) > 2 else "tests"]


def _equivalents() -> dict[tuple[str, str], str]:
    """(function, changed line) -> reason, from ``scripts/mutation-equivalent.txt``."""
    out: dict[tuple[str, str], str] = {}
    if not EQUIVALENT_FILE.exists():
        return out
    for number, line in enumerate(EQUIVALENT_FILE.read_text(encoding="utf-8").splitlines(), 1):
        if not line.strip() or line.startswith("#"):
            continue
        try:  # the changed line may hold " | " itself (a type union); the reason may not
            function, rest = line.split(" | ", 1)
            changed, reason = rest.rsplit(" | ", 1)
            function, changed, reason = function.strip(), changed.strip(), reason.strip()
        except ValueError:
            sys.exit(f"{EQUIVALENT_FILE.name}:{number}: expected 'function | changed line | "
                     "reason'")
        out[(function, changed)] = reason
    return out


def signature(name: str, diff: str) -> tuple[str, str]:
    """A survivor's key that outlives mutmut's numbering: its function and its changed lines
    (a deleted line, which has none, as ``deleted: LINE``)."""
    function = name.rsplit("__mutmut_", 1)[0]
    lines = diff.splitlines()
    changed = " / ".join(line[1:].strip() for line in lines
                         if line.startswith("+") and not line.startswith("+++"))
    if not changed:
        changed = " / ".join(f"deleted: {line[1:].strip()}" for line in lines
                             if line.startswith("-") and not line.startswith("---"))
    return function, changed


def _project_files() -> list[str]:
    """The project's files, tracked or new (not ignored): what a fresh clone would have."""
    out = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard", "-z"],
                         cwd=ROOT, check=True, stdout=subprocess.PIPE).stdout
    return [p for p in out.decode().split("\0") if p and (ROOT / p).is_file()]


def _prepare(work: Path, module: str, base: dict[str, object], tests: list[str]) -> None:
    # A fresh copy of the project: the tests also read routines, schemas and examples.
    shutil.rmtree(work, ignore_errors=True)
    files = _project_files()
    for rel in files:
        (work / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / rel, work / rel)
    _configure(work, module, base, tests, files)


def _configure(work: Path, module: str, base: dict[str, object], tests: list[str],
               files: list[str]) -> None:
    """The scratch copy's pyproject.toml: pytest's options and mutmut's, with ``tests``."""
    ini = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    ini = ini["tool"]["pytest"]["ini_options"]
    # mutmut runs the tests in its mutants/ copy: everything at the top is copied there too.
    tops = sorted({Path(rel).parts[0] for rel in files} - {"xgo_show", "tests", "pyproject.toml"})
    mutmut = {**base, "only_mutate": [module], "pytest_add_cli_args_test_selection": tests,
              "also_copy": [*list(base.get("also_copy", [])), *tops]}  # type: ignore[call-overload]
    lines = ["[tool.pytest.ini_options]"]
    lines += [f"{k} = {_toml_value(v)}" for k, v in ini.items()]
    lines += ["", "[tool.mutmut]"]
    lines += [f"{k} = {_toml_value(v)}" for k, v in mutmut.items()]
    (work / "pyproject.toml").write_text("\n".join(lines) + "\n", encoding="utf-8")


def _mutmut(work: Path, *args: str, log: Path | None = None) -> str:
    """Run one mutmut command in ``work``; with ``log``, its output goes there as it comes."""
    exe = Path(sys.executable).with_name("mutmut")
    if log is not None:
        with log.open("w", encoding="utf-8") as out:
            code = subprocess.run([str(exe), *args], cwd=work, stdout=out,
                                  stderr=subprocess.STDOUT, check=False).returncode
        text = ""
    else:
        proc = subprocess.run([str(exe), *args], cwd=work, text=True, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, check=False)
        code, text = proc.returncode, proc.stdout
    if code != 0:
        raise RuntimeError(f"mutmut {args[0]} failed (exit {code}); see {log or work}")
    return text


# One process for all of a module's survivors (``mutmut show`` takes seconds for each).
_DIFFS = """
import json, sys
from mutmut.mutation.diff_apply import get_diff_for_mutant
json.dump({n: get_diff_for_mutant(n) for n in json.load(sys.stdin)}, sys.stdout)
"""


def _diffs(work: Path, names: list[str]) -> dict[str, str]:
    """Each mutant's diff against the original, as ``mutmut show`` prints it."""
    if not names:
        return {}
    proc = subprocess.run([sys.executable, "-c", _DIFFS], cwd=work, input=json.dumps(names),
                          text=True, stdout=subprocess.PIPE, check=True)
    diffs: dict[str, str] = json.loads(proc.stdout)
    return diffs


CARRIED = "caught-before.json"  # in a scratch copy: mutants caught by an earlier run


def _statuses(work: Path) -> list[tuple[str, str]]:
    """(mutant, status) for every mutant of the last run in ``work`` (those a survivors run did
    not run again: as an earlier run left them)."""
    results = _mutmut(work, "results", "--all", "true")
    carried = (json.loads((work / CARRIED).read_text()) if (work / CARRIED).exists() else {})
    return [(name, carried.get(name, status) if status == "not checked" else status)
            for name, status in
            (line.strip().rsplit(": ", 1) for line in results.splitlines() if ": " in line)]


def _module_changed(work: Path, module: str) -> bool:
    """Whether the mutated module differs from the scratch copy's (unmutated) one: its mutants
    would no longer be the module's. Other modules may have moved on (a rebase): the survivors
    run against the scratch copy's code, and mutmut first runs their tests on it unmutated,
    stopping if a test needs newer code than the copy has."""
    return (ROOT / module).read_bytes() != (work / module).read_bytes()


def _refresh_tests(work: Path) -> None:
    """Copy the project's current tests over the scratch copy's (mutmut copies them on)."""
    for rel in _project_files():
        if rel.startswith("tests/"):
            (work / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / rel, work / rel)


def run_module(module: str, work_root: Path, base: dict[str, object],
               named: dict[str, list[str]], equivalent: dict[tuple[str, str], str],
               *, mode: str = "all", children: int = 1) -> Outcome:
    """Mutate ``module`` in its own scratch copy and classify what survived. ``mode``:
    ``all`` runs every mutant afresh; ``survivors`` runs the last run's survivors again
    against the current tests; ``report`` only classifies the last run's results. ``children``:
    mutants tested at once (mutmut's ``--max-children``)."""
    outcome = Outcome(module)
    work = work_root / module.replace("/", "_").removesuffix(".py")
    start = time.monotonic()
    try:
        if mode == "all":
            _prepare(work, module, base, test_folders(module, named))
            _mutmut(work, "run", "--max-children", str(children), log=work / "run.log")
        elif not (work / "mutants").is_dir():
            raise RuntimeError(f"no earlier run in {work}")
        elif mode == "survivors":
            if _module_changed(work, module):
                raise RuntimeError("the module changed since the last full run: run it in full")
            before = dict(_statuses(work))
            again = [name for name, status in before.items() if status not in CAUGHT]
            if again:
                _refresh_tests(work)
                # The tests named for the module now (a test file added since the full run).
                _configure(work, module, base, test_folders(module, named), _project_files())
                # mutmut makes its mutants afresh when its configuration changed (the tests
                # named for the module), forgetting earlier results: those caught stay caught
                # (tests were only added since).
                (work / CARRIED).write_text(json.dumps(
                    {name: status for name, status in before.items() if status in CAUGHT}))
                _mutmut(work, "run", "--max-children", str(children), *again,
                        log=work / "rerun.log")
        _mutmut(work, "export-cicd-stats")
        stats = json.loads((work / "mutants" / "mutmut-cicd-stats.json").read_text())
        statuses = _statuses(work)

    except RuntimeError as exc:
        outcome.error = str(exc)
        return outcome
    finally:
        outcome.seconds = time.monotonic() - start
    for _, status in statuses:
        outcome.counts[status] = outcome.counts.get(status, 0) + 1
    if sum(outcome.counts.values()) != stats["total"]:
        outcome.error = f"results list {sum(outcome.counts.values())} of {stats['total']} mutants"
    left = {name: status for name, status in statuses if status not in CAUGHT}
    for name, diff in _diffs(work, list(left)).items():
        reason = equivalent.get(signature(name, diff))
        if reason is not None:
            outcome.equivalent.append((name, reason))
        else:
            outcome.survivors.append((name, f"[{left[name]}]\n{diff.strip()}"))
    (work / "survivors.txt").write_text(
        "\n\n".join(f"{n}\n{d}" for n, d in outcome.survivors) + "\n", encoding="utf-8")
    return outcome


def report(outcomes: list[Outcome]) -> str:
    """The summary table (Markdown) and the survivors to look at."""
    rows = ["| module | mutants | caught | equivalent | survived | kill rate | time |",
            "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for o in outcomes:
        if o.error:
            rows.append(f"| {o.module} | error: {o.error} | | | | | {o.seconds:.0f} s |")
            continue
        rows.append(f"| {o.module} | {o.total} | {o.caught} | {len(o.equivalent)} | "
                    f"{len(o.survivors)} | {o.rate:.1f} % | {o.seconds:.0f} s |")
    lines = ["\n".join(rows)]
    for o in outcomes:
        for name, diff in o.survivors:
            lines.append(f"\n## {name}\n{diff}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="scripts/mutation.sh", description=__doc__.split("\n")[0])
    parser.add_argument("modules", nargs="*", help="files to mutate, e.g. xgo_show/wire/xgo.py "
                        "(default: [tool.xgo-show.mutation] modules)")
    parser.add_argument("-j", "--jobs", type=int, default=2,
                        help="modules mutated at once (default 2)")
    parser.add_argument("-c", "--children", type=int, default=1,
                        help="test processes per module (default 1); on a shared machine keep "
                        "jobs x children at 2 or less, e.g. -j 1 -c 2 for one big module")
    parser.add_argument("--work", type=Path,
                        default=Path(os.environ.get("TMPDIR", "/tmp")) / "xgo-show-mutation",
                        help="scratch folder (one copy of the project per module)")
    how = parser.add_mutually_exclusive_group()
    how.add_argument("--survivors", action="store_const", const="survivors", dest="mode",
                     default="all", help="run only the last run's survivors again, against "
                     "the current tests (after writing tests for them)")
    how.add_argument("--report", action="store_const", const="report", dest="mode",
                     help="run nothing: classify the last run's survivors again (after "
                     "editing scripts/mutation-equivalent.txt)")
    args = parser.parse_args(argv)
    base, ours = _settings()
    named = {k: list(v) for k, v in dict(ours.get("tests", {})).items()}  # type: ignore[call-overload]
    modules = args.modules or list(ours.get("modules", []))  # type: ignore[call-overload]
    for module in modules:
        if not (ROOT / module).is_file() or not module.startswith("xgo_show/"):
            parser.error(f"{module}: not a module of the package (give xgo_show/.../name.py)")
    equivalent = _equivalents()
    with concurrent.futures.ThreadPoolExecutor(max(1, args.jobs)) as pool:
        futures = [pool.submit(run_module, m, args.work, base, named, equivalent,
                               mode=args.mode, children=max(1, args.children))
                   for m in modules]
        outcomes = []
        for future in futures:
            outcome = future.result()
            outcomes.append(outcome)
            if outcome.error:
                print(f"{outcome.module}: ERROR {outcome.error}", flush=True)
                continue
            print(f"{outcome.module}: {outcome.rate:.1f} % ({outcome.caught}/"
                  f"{outcome.total - len(outcome.equivalent)}) in {outcome.seconds:.0f} s",
                  flush=True)
    print()
    print(report(outcomes))
    return 1 if any(o.error for o in outcomes) else 0


if __name__ == "__main__":
    sys.exit(main())
