"""buildhat-conformance run: the conformance suite against one target.

Before any case runs the target is checked (harness/preflight.py: it exists, is a serial
device, something listens, the release is known, --firmware is valid, something answers);
a problem is one line and exit status 2 (usage) or 3 (unreachable), and no report is
touched. Then pytest runs the suite's cases (conformance/cases/) in a child process (so a
target that hangs or dies cannot take the caller with it), writes the JUnit file, and the
HTML report is built. pytest's own options go after ``--`` and are passed on unchanged
(conformance/run_passthrough.py: which others still go on, and which are mistakes).

The child and everything it starts end with this process: it has its own process group, a
parent-death signal (plumbing/parent_death.py), and on Ctrl-C or SIGTERM it is told to stop,
which closes the target and writes the JUnit file marked partial (conformance/plugin/interrupt.py);
the HTML report is still built.
"""
from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time
from typing import List, Optional, Tuple

from ..plumbing.cli_options import (
    DEFAULT_SPEED,
    DEFAULT_TARGET,
    EXIT_FAILED,
    EXIT_OK,
    EXIT_TARGET,
    expand_target,
)
from ..plumbing.parent_death import die_with_parent
from .case_order import order_argv, resolve_seed

__all__ = ["run", "pytest_argv", "suite_dir"]
EXIT_INTERRUPTED = 130
_STOP_GRACE_S = 15.0       # the child closes the target and writes its files in this time
# pytest's exit statuses: 0 all passed, 1 some failed, 2 interrupted, 3 internal error,
# 4 usage error, 5 no tests collected.
_PYTEST_TO_EXIT = {0: EXIT_OK, 1: EXIT_FAILED, 2: EXIT_INTERRUPTED, 3: EXIT_TARGET, 4: 2, 5: 2}
# Options passed through to pytest that need pytest-xdist (several targets, or workers).
_XDIST_OPTIONS = {"--inventory", "-n", "--numprocesses", "--dist", "--tx", "-d", "--looponfail", "-f"}


def suite_dir() -> str:
    """The folder of the conformance cases (conformance/cases/)."""
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), "cases")


def _targets(args: argparse.Namespace) -> List[str]:
    if isinstance(args.target, list):
        return args.target
    return [args.target or DEFAULT_TARGET]


def pytest_argv(args: argparse.Namespace) -> List[str]:
    junit = os.path.abspath(args.junit)
    transcripts = args.transcripts or os.path.join(os.path.dirname(junit), "transcripts")
    # H10: --target may be given several times (conformance/plugin/multitarget.py runs one worker each).
    targets = _targets(args)
    argv = [sys.executable, "-m", "pytest", suite_dir(), "-p", "no:cacheprovider", "--rootdir", suite_dir(),
            *[a for t in targets for a in ("--target", t)], "--conformance-junit", junit,
            "--transcripts", transcripts, "--import-mode=importlib", "-q",
            # A case says what failed in its own words (conformance/mismatch.py), never pytest's rewriting.
            "--assert=plain",
            # The suite uses no Hypothesis (a dev dependency only); where it is installed, its pytest
            # plugin imports the library in the terminal summary, two seconds of every run (H10 profile).
            "-p", "no:hypothesispytest",
            "-p", "buildhat_conformance.conformance.plugin.interrupt",
            # The host-library fixture plugin (emulator/host_fixtures/pytest_plugin.py) is not the suite's.
            "-p", "no:buildhat_emulator",
            # pytest's closing gc.collect() passes over the whole session's heap (twice): a tenth
            # of a virtual-time run in the profile; the suite raises nothing in __del__ to report.
            "-p", "no:unraisableexception",
            # pyserial's RFC 2217 client (labgrid places) uses threading names deprecated in 3.10
            "-W", "ignore::DeprecationWarning:serial.rfc2217"]
    extra = list(getattr(args, "extra", []) or [])
    if len(targets) == 1 and not getattr(args, "inventory", None) and not any(
            a.split("=")[0] in _XDIST_OPTIONS or a.startswith("-n") for a in extra):
        # One target: no xdist workers (conformance/plugin/multitarget.py), so not its plugins either.
        argv += ["-p", "no:xdist", "-p", "no:xdist.looponfail"]
    argv += ["--conformance-html", os.path.join(os.path.dirname(junit), "index.html")]
    if getattr(args, "inventory", None):
        argv += ["--inventory", os.path.abspath(args.inventory)]
    if getattr(args, "speed", None):
        argv += ["--speed", f"{args.speed:g}"]
    if args.firmware:
        argv += ["--firmware", args.firmware]
    if args.keyword:
        argv += ["-k", args.keyword]
    if getattr(args, "max_target_faults", None) is not None:
        argv += ["--max-target-faults", str(args.max_target_faults)]
    if getattr(args, "image", None) and getattr(args, "signature", None):
        # loaded before the suite (load_image_first) and again if the run resets a dead HAT
        argv += ["--image", os.path.abspath(args.image), "--signature", os.path.abspath(args.signature)]
    if args.operator:
        argv += ["--operator", "-s"]
    # the suite's own order, or shuffled by pytest-randomly with this seed (conformance/case_order.py)
    argv += order_argv(getattr(args, "random_order_seed", None))
    return argv + extra


def preflight(args: argparse.Namespace) -> None:
    """Check every target before the run (raises UsageError or TargetError, one line each)."""
    from ..harness.preflight import check_answers, check_release, checked_target
    from ..plumbing.cli_options import check_writable

    judged = check_release(args.firmware, "--firmware") if args.firmware else None
    if args.junit:
        check_writable(args.junit, "--junit")
    else:   # a new run folder under reports/runs/ (conformance/report/runs.py)
        from .report import runs

        check_writable(os.path.join(runs.DEFAULT_ROOT, runs.RUNS), "the run folder", folder=True)
    if args.transcripts:
        check_writable(args.transcripts, "--transcripts", folder=True)
    from ..harness.errors import BrokenClause
    from ..harness.targets.base import TargetError
    from .plugin.run_outcome import release_mismatch

    urls = _inventory_urls(args.inventory) if getattr(args, "inventory", None) else _targets(args)
    for url in urls:
        url = expand_target(url, getattr(args, "speed", DEFAULT_SPEED))
        target = checked_target(url)
        try:
            answer = check_answers(target)
        except BrokenClause as exc:     # a Build HAT: the run's case of that clause fails (plugin/run.py)
            print(f"buildhat-conformance run: {exc}; the run reports it as that clause's failure",
                  file=sys.stderr)
            continue
        if answer.in_bootloader and not getattr(args, "image", None):
            raise TargetError(f"{url} answers from its bootloader ({answer.version_string}): no firmware "
                              "is running; load a release first (buildhat-conformance load)")
        if judged is not None:
            mismatch = release_mismatch(url, answer.version_string, judged)
            if mismatch is not None:     # the run could not do its job: exit 3, one line
                raise TargetError(mismatch)
            print(f"buildhat-conformance run: {url} runs firmware {answer.version_string or 'unknown'}; "
                  f"judged as {judged.name} ({judged.number}) because of --firmware", file=sys.stderr)


def _seed(args: argparse.Namespace) -> Optional[int]:
    """The seed of ``--random-order`` (None: the suite's own order); a wrong one is a usage error."""
    from ..plumbing.cli_options import UsageError

    try:
        return resolve_seed(getattr(args, "random_order", None))
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def _inventory_urls(path: str) -> List[str]:
    """The URLs of an inventory file; its mistakes are one line naming the file and line."""
    import pytest

    from ..plumbing.cli_options import UsageError
    from .plugin.multitarget import read_inventory

    try:
        found = read_inventory(path)
    except FileNotFoundError:
        raise UsageError(f"--inventory {path}: no such file") from None
    except OSError as exc:
        raise UsageError(f"--inventory {path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise UsageError(f"--inventory {path}: not a text file") from None
    except pytest.UsageError as exc:
        raise UsageError(str(exc)) from None
    if not found:
        raise UsageError(f"--inventory {path}: lists no target")
    return [url for _name, url in found]


def _missing_folders(path: str) -> List[str]:
    """``path`` and those of its parents that do not exist yet, deepest first."""
    missing: List[str] = []
    path = os.path.abspath(path)
    while not os.path.exists(path):
        missing.append(path)
        path = os.path.dirname(path)
    return missing


def _remove_if_empty(folders: List[str]) -> None:
    """Take back the folders this run made (deepest first) if nothing was left in them."""
    for path in folders:
        try:
            os.rmdir(path)
        except FileNotFoundError:
            continue
        except OSError:
            return      # not empty (a run wrote there): leave it and its parents


def build_html_report(junit: str) -> None:
    """Write ``index.html`` beside the JUnit file; the suite's closing line has named it."""
    from .report import build_report

    try:
        build_report([junit], os.path.join(os.path.dirname(junit), "index.html"))
    except Exception as exc:  # noqa: BLE001 - the report is extra; the verdict is the exit status
        print(f"buildhat-conformance run: HTML report not built: {exc}", file=sys.stderr)


def _kill_group(pgid: int, sig: int) -> None:
    try:
        os.killpg(pgid, sig)
    except (ProcessLookupError, PermissionError):
        pass


def run_child(argv: List[str]) -> Tuple[int, Optional[int]]:
    """Run the pytest child in its own process group, ending it (and what it started) when
    this process gets SIGINT or SIGTERM. Returns (its exit status, the signal that stopped us
    or None)."""
    proc = subprocess.Popen(argv, start_new_session=True, preexec_fn=die_with_parent(signal.SIGTERM))
    got: List[int] = []
    stop_at: List[float] = []

    def on_signal(sig: int, _frame: object) -> None:
        if not got:
            got.append(sig)
            stop_at.append(time.monotonic() + _STOP_GRACE_S)
            _kill_group(proc.pid, signal.SIGTERM)   # the child's handler turns it into a clean stop

    old = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        while True:
            try:
                code = proc.wait(timeout=0.2)
                break
            except subprocess.TimeoutExpired:
                pass
            if stop_at and time.monotonic() > stop_at[0]:
                _kill_group(proc.pid, signal.SIGKILL)
    finally:
        for s, handler in old.items():
            signal.signal(s, handler)
        _kill_group(proc.pid, signal.SIGKILL)   # anything of its group still there
    return code, (got[0] if got else None)


def load_image_first(args: argparse.Namespace) -> int:
    """``--image/--signature``: load the release under test into every target before any case
    runs (harness/bootloader/). Returns 0, or the exit status of a failed load (one line said why)."""
    from ..harness.bootloader.errors import EXIT_USAGE, LoadError
    from ..harness.bootloader.files import load_files
    from ..harness.targets import TargetError, make_target

    prog = "buildhat-conformance run"
    if not (args.image and args.signature):
        print(f"{prog}: --image and --signature go together (the bootloader needs both)", file=sys.stderr)
        return EXIT_USAGE
    targets = args.target if isinstance(args.target, list) else [args.target or "emulator"]
    for url in targets:
        try:
            disposable = make_target(url).disposable
        except TargetError as exc:
            print(f"{prog}: {' '.join(str(exc).split())}", file=sys.stderr)
            return EXIT_USAGE
        if disposable:
            print(f"{prog}: --image needs a HAT that outlives one connection, and {url} starts a new one for "
                  "each; start one with 'buildhat-emulator --pty --bootloader --link /tmp/hat' and use "
                  "--target /tmp/hat", file=sys.stderr)
            return EXIT_USAGE
        transcript = os.path.join(os.path.dirname(os.path.abspath(args.junit)), "load.jsonl")
        try:
            result = load_files(url, args.image, args.signature, transcript=transcript)
        except LoadError as exc:
            print(f"{prog}: loading {args.image} into {url}: {exc}", file=sys.stderr)
            return exc.exit_status
        print(f"loaded: firmware version {result.firmware_version} into {url}", flush=True)
    return 0


def _baseline_checks(args: argparse.Namespace) -> list:
    """``--baseline``/``--expect-changes`` checked before anything runs; the expected changes."""
    from ..plumbing.cli_options import UsageError
    from .comparison import read_expect_changes

    baseline = getattr(args, "baseline", None)
    expect = getattr(args, "expect_changes", None)
    if expect is not None and baseline is None:
        raise UsageError("--expect-changes needs --baseline (the build the changes are made against)")
    if baseline is None:
        return []
    if len(_targets(args)) != 1 or getattr(args, "inventory", None):
        raise UsageError("--baseline compares one target with one baseline: give one --target")
    if args.image or args.signature:
        raise UsageError("--baseline runs the suite on two targets; --image would load only one of them")
    return read_expect_changes(expect) if expect is not None else []


def _preflight_baseline(args: argparse.Namespace) -> None:
    """The baseline checked as the target is; its problem says it is the baseline's."""
    from ..harness.targets.base import TargetError
    from ..plumbing.cli_options import UsageError

    try:
        preflight(argparse.Namespace(**{**vars(args), "target": [args.baseline], "inventory": None}))
    except UsageError as exc:
        raise UsageError(f"--baseline: {exc}") from None
    except TargetError as exc:
        raise TargetError(f"--baseline: {exc}") from None


def run(args: argparse.Namespace) -> int:
    """The run: preflight, a new run folder, the image loaded if given, the suite in a child pytest,
    the report; the exit status of the table in cli_exits.py."""
    from .report import runs

    expected = _baseline_checks(args)
    preflight(args)   # before the run folder and the load: a mistake is one line, reports/ untouched
    seed = args.random_order_seed = _seed(args)
    if seed is not None:
        print(f"buildhat-conformance run: cases in a shuffled order, seed {seed} (the same order again: "
              f"--random-order {seed})", flush=True)
    if getattr(args, "baseline", None):
        _preflight_baseline(args)
    made = _missing_folders(os.path.join(runs.DEFAULT_ROOT, runs.RUNS)) if not args.junit else []
    folder = runs.start_for(args)        # None when --junit names the file explicitly
    if args.image or args.signature:
        status = load_image_first(args)
        if status:
            if folder is not None:
                print(runs.finish(folder))   # no case ran: reports/ stays as it was
                _remove_if_empty(made)
            return status
    junit = os.path.abspath(args.junit)
    baseline = _start_baseline(args, junit) if getattr(args, "baseline", None) else None
    # The suite's own folder is the rootdir; pytest.ini options of the caller's project are not ours.
    if baseline is not None:
        with baseline.slots:
            code, stopped_by = run_child(pytest_argv(args))
    else:
        code, stopped_by = run_child(pytest_argv(args))
    if stopped_by is not None:
        print(f"buildhat-conformance run: interrupted ({signal.Signals(stopped_by).name}); the cases that "
              f"ran are in {args.junit} (marked partial)", file=sys.stderr)
    differ = False
    if baseline is not None:
        if stopped_by is not None:
            baseline.stop()
        compared = _finish_baseline(args, baseline, junit, expected) if stopped_by is None else None
        if compared is None and stopped_by is None:
            code = 3        # the comparison, which the run was for, could not be made
        differ = bool(compared)
    if os.path.isfile(junit) and (folder is None or runs.cases_ran(folder.junit)):
        build_html_report(junit)
    if folder is not None:
        print(runs.finish(folder))
        _remove_if_empty(made)     # nothing ran (e.g. pytest refused an option after --)
    if stopped_by is not None:
        return EXIT_INTERRUPTED
    if code == 3:
        return EXIT_TARGET
    status = _PYTEST_TO_EXIT.get(code, EXIT_FAILED if code else EXIT_OK)
    return EXIT_FAILED if differ and status == EXIT_OK else status


def _start_baseline(args: argparse.Namespace, junit: str):  # type: ignore[no-untyped-def]
    """Start the baseline's runs beside the target's (conformance/baseline_runs.py)."""
    import threading
    from pathlib import Path

    from .baseline_runs import BaselineRuns

    folder = Path(os.path.dirname(junit)) / "baseline"
    runs_ = BaselineRuns(args, folder, pytest_argv, threading.Semaphore(2))
    print(f"buildhat-conformance run: the baseline {args.baseline} runs the suite {len(runs_.names)} times "
          f"beside this run (logs in {folder})", flush=True)
    runs_.start()
    return runs_


def _finish_baseline(args: argparse.Namespace, baseline, junit: str,  # type: ignore[no-untyped-def]
                     expected: list) -> Optional[bool]:
    """Wait for the baseline's runs, compare, write the comparison into the JUnit file and print
    it. Returns whether a difference fails the run (one outside --expect-changes), None when the
    baseline left nothing to compare with."""
    from pathlib import Path

    from .comparison import annotate_junit, closing_lines, compare_runs

    junits = baseline.wait()
    first = baseline.folder / "reference" / "junit.xml"
    if not junits or junits[0] != first or not os.path.isfile(junit):
        why = (f"the baseline's run left no JUnit file ({baseline.reference_log()})" if not junits or
               junits[0] != first else "this run left no JUnit file")
        print(f"buildhat-conformance run: no comparison with {args.baseline}: {why}", file=sys.stderr)
        return None
    comparison = compare_runs(args.baseline, Path(junit), junits, expected)
    annotate_junit(Path(junit), comparison)
    for line in closing_lines(comparison, args.expect_changes):
        print(line)
    return bool(comparison.unexpected) if args.expect_changes is not None else False
