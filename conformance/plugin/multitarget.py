"""Several HATs at once: one pytest-xdist worker per target, one merged JUnit report.

    pytest conformance/cases --target emulator:R5 --target emulator:R7 --target /dev/ttyUSB0
    pytest conformance/cases --inventory lab.txt          # or: buildhat-conformance run --inventory lab.txt

An inventory is a text file, one HAT per line: a name, then its target URL (``#`` starts a
comment; a line with only a URL is named after its position)::

    bench-a   /dev/serial/by-id/usb-Raspberry_Pi_Build_HAT_A-if00
    bench-b   serial:///dev/ttyUSB1?baud=115200
    emu-r5    emulator:R5

With more than one target the run is spread with xdist in ``--dist each`` mode (every worker
runs the whole suite), ``-n`` set to the number of targets unless given; worker ``gw<i>`` owns
target ``i``. Each worker keeps its own session, transcripts (``<transcripts>/<name>/``) and
JUnit file (``<junit>.targets/<name>.xml``); at the end the controller merges them into the
``--conformance-junit`` file: one ``<testsuite>``, every case's classname prefixed with its
target's name and a ``target_name`` property beside the plugin's ``target`` URL.

Loaded by ``conformance/cases/conftest.py`` (``pytest_plugins``); without several targets it does
nothing.
"""
from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ET
from collections import Counter
from typing import Any, List, Optional, Sequence, Tuple

import pytest

__all__ = ["Target", "read_inventory", "targets_of", "merge_junit", "merged_exit_status"]

Target = Tuple[str, str]          # (name, URL)


def pytest_addoption(parser: Any) -> None:
    group = parser.getgroup("buildhat", "Build HAT conformance")
    group.addoption("--inventory", default=None, metavar="FILE",
                    help="run against every HAT listed in FILE (one 'name URL' per line), one xdist "
                         "worker per HAT, results merged into one report")


def read_inventory(path: str) -> List[Target]:
    """(name, URL) pairs from an inventory file (see the module docstring)."""
    out: List[Target] = []
    with open(path, encoding="utf-8") as fh:
        for lineno, raw in enumerate(fh, 1):
            line = raw.split("#", 1)[0].strip()
            if not line:
                continue
            words = line.split()
            if len(words) == 1:
                out.append((f"target{len(out)}", words[0]))
            elif len(words) == 2:
                out.append((words[0], words[1]))
            else:
                raise pytest.UsageError(f"{path}:{lineno}: expected 'NAME URL' or 'URL', got {line!r}")
    names = [n for n, _ in out]
    dup = [n for n, c in Counter(names).items() if c > 1]
    if dup:
        raise pytest.UsageError(f"{path}: target names must be unique ({', '.join(dup)} repeated)")
    return out


def _repeated_targets(args: Sequence[str]) -> List[str]:
    """Every ``--target`` value on the command line (the main option keeps only the last)."""
    urls: List[str] = []
    it = iter(args)
    for a in it:
        if a == "--target":
            urls.append(next(it, ""))
        elif a.startswith("--target="):
            urls.append(a.split("=", 1)[1])
    return urls


def _name_for(url: str, index: int) -> str:
    base = re.sub(r"[^A-Za-z0-9_.-]+", "_", url.split("?", 1)[0]).strip("_") or "target"
    return f"{index}-{base}"


def targets_of(config: Any) -> List[Target]:
    """The targets of this run: the inventory, or ``--target`` given more than once."""
    inventory = config.getoption("inventory", None)
    if inventory:
        return read_inventory(inventory)
    urls = _repeated_targets(list(config.invocation_params.args))
    if len(urls) > 1:
        return [(_name_for(u, i), u) for i, u in enumerate(urls)]
    return []


def _worker_index(config: Any) -> Optional[int]:
    wid = getattr(config, "workerinput", {}).get("workerid", "")
    m = re.fullmatch(r"gw(\d+)", wid)
    return int(m.group(1)) if m else None


def _part_path(junit: str, name: str) -> str:
    return os.path.join(f"{junit}.targets", f"{name}.xml")


@pytest.hookimpl(tryfirst=True)
def pytest_cmdline_main(config: Any) -> None:
    """Before xdist reads its options: one worker per target, every worker runs every test."""
    targets = targets_of(config)
    if len(targets) < 2 or hasattr(config, "workerinput"):
        return
    if not config.pluginmanager.hasplugin("xdist"):
        from ...plumbing.optional_extras import install_hint

        raise pytest.UsageError(f"several targets need pytest-xdist: {install_hint('parallel')}")
    if config.option.numprocesses in (None, 0):
        config.option.numprocesses = len(targets)
    config.option.dist = "each"


@pytest.hookimpl(trylast=True)
def pytest_configure(config: Any) -> None:
    targets = targets_of(config)
    if len(targets) < 2:
        return
    if not hasattr(config, "workerinput"):
        n = config.option.numprocesses
        if isinstance(n, int) and n != len(targets):
            raise pytest.UsageError(f"{len(targets)} targets need -n {len(targets)} (one worker each), "
                                    f"got -n {n}")
        # The controller runs no test: its single-target SuiteRun would see every worker's reports
        # under the same node IDs. The merged report is written here instead.
        config.pluginmanager.unregister(name="buildhat-conformance-run")
        config.pluginmanager.register(_Merge(config, targets), "buildhat-conformance-merge")
        return
    index = _worker_index(config)
    if index is None or index >= len(targets):
        raise pytest.UsageError(f"worker {config.workerinput.get('workerid')!r} has no target "
                                f"({len(targets)} targets)")
    from .run import SuiteRun, _run_key

    name, url = targets[index]
    junit = config.getoption("conformance_junit")
    config.option.target = url
    config.option.conformance_junit = _part_path(junit, name)
    config.option.transcripts = os.path.join(config.getoption("transcripts"), name)
    run = SuiteRun(config)
    run.junit.set_property("target_name", name)
    config.stash[_run_key] = run
    config.pluginmanager.register(run, "buildhat-conformance-run")


class _Merge:
    """Controller side: merge the workers' JUnit files and summarise per target."""

    def __init__(self, config: Any, targets: List[Target]):
        self.config = config
        self.targets = targets
        self.junit = config.getoption("conformance_junit")

    def pytest_sessionfinish(self, session: Any, exitstatus: Any) -> None:
        parts = [(name, url, _part_path(self.junit, name)) for name, url in self.targets]
        merge_junit(parts, self.junit)
        if int(exitstatus) in (0, 1):
            # xdist counts a worker's target fault as an error (1); the agreed statuses are the
            # single run's (plugin.SuiteRun.exit_status): 1 a failure, else 3 a target fault, else 0.
            session.exitstatus = merged_exit_status(parts)

    def pytest_terminal_summary(self, terminalreporter: Any) -> None:
        tr = terminalreporter
        tr.section("conformance per target")
        for name, url in self.targets:
            path = _part_path(self.junit, name)
            if not os.path.exists(path):
                tr.write_line(f"{name:<16} {url}: no results (the worker did not start?)")
                continue
            verdicts: Counter = Counter()
            for tc in ET.parse(path).getroot().iter("testcase"):
                props = {p.get("name"): p.get("value") for p in tc.iter("property")}
                verdicts[props.get("verdict", "?")] += 1
            tr.write_line(f"{name:<16} {url}: " + ", ".join(f"{v} {k}" for k, v in sorted(verdicts.items())))
        tr.write_line(f"merged JUnit: {self.junit}")


def merged_exit_status(parts: Sequence[Tuple[str, str, str]]) -> int:
    """1 if a case failed on any target, else 3 if a target faulted, stopped or left no results,
    else 0."""
    verdicts = set()
    for _name, _url, path in parts:
        if not os.path.exists(path):
            verdicts.add("not-run")
            continue
        for tc in ET.parse(path).getroot().iter("testcase"):
            verdicts.update(p.get("value") for p in tc.iter("property") if p.get("name") == "verdict")
    if "fail" in verdicts:
        return 1
    return 3 if verdicts & {"target-fault", "not-run"} else 0


def merge_junit(parts: Sequence[Tuple[str, str, str]], out: str) -> int:
    """One ``<testsuite>`` from the per-target files ``(name, url, path)``; returns the cases."""
    suite = ET.Element("testsuite", name="buildhat-conformance")
    props = ET.SubElement(suite, "properties")
    ET.SubElement(props, "property", name="targets",
                  value=", ".join(f"{name}={url}" for name, url, _ in parts))
    counts = Counter()
    total_time = 0.0
    for name, url, path in parts:
        if not os.path.exists(path):
            ET.SubElement(props, "property", name=f"missing:{name}", value=url)
            continue
        part = ET.parse(path).getroot()
        for prop in part.findall("./testsuite/properties/property"):
            if prop.get("name") != "target_name":      # firmware, profile ... of this target
                ET.SubElement(props, "property", name=f"{name}:{prop.get('name')}",
                              value=prop.get("value", ""))
        for tc in part.iter("testcase"):
            tc.set("classname", f"{name}.{tc.get('classname', '')}")
            case_props = tc.find("properties")
            if case_props is None:
                case_props = ET.SubElement(tc, "properties")
            ET.SubElement(case_props, "property", name="target_name", value=name)
            for tag in ("failure", "error", "skipped"):
                if tc.find(tag) is not None:
                    counts[tag] += 1
            counts["tests"] += 1
            total_time += float(tc.get("time") or 0.0)
            suite.append(tc)
    suite.set("tests", str(counts["tests"]))
    suite.set("failures", str(counts["failure"]))
    suite.set("errors", str(counts["error"]))
    suite.set("skipped", str(counts["skipped"]))
    suite.set("time", f"{total_time:.3f}")
    root = ET.Element("testsuites")
    root.append(suite)
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    tmp = f"{out}.tmp{os.getpid()}"
    ET.ElementTree(root).write(tmp, encoding="utf-8", xml_declaration=True)
    os.replace(tmp, out)
    return counts["tests"]
