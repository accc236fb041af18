"""The emulator's import rules, read from the source (ast), TYPE_CHECKING and function-local
imports included:

- no import circle among the modules under emulator/;
- only the composition root's users (api.py, cli.py, script_mode.py) import emulator/hat.py: the parts
  (ports, controllers, faults, start-up, commands, ...) see the HAT through the Protocols of
  emulator/services.py and emulator/commands/context.py.
"""
from __future__ import annotations

import ast
from pathlib import Path
from typing import Dict, List, Set

import buildhat_conformance.emulator as emulator_pkg

PACKAGE = "buildhat_conformance"
ROOT = Path(emulator_pkg.__file__).resolve().parent        # the emulator/ folder
HAT = "emulator.hat"
HAT_USERS = ("emulator.api", "emulator.cli", "emulator.script_mode")


def _module_name(path: Path) -> str:
    parts = ["emulator", *path.relative_to(ROOT).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> Dict[str, Path]:
    return {_module_name(p): p for p in sorted(ROOT.rglob("*.py"))}


def _imports(name: str, path: Path, known: Set[str]) -> Set[str]:
    """The emulator modules ``name`` imports (``from X import y`` counts as X.y when that is a
    module, else as X)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    here = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    found: Set[str] = set()

    def add(target: str, names: List[str]) -> None:
        for alias in names or [""]:
            full = f"{target}.{alias}" if alias else target
            mod = full if full in known else target
            # Importing a.b.c runs the package a.b first (emulator/ itself imports nothing
            # at load time: its ``Emulator`` attribute is looked up lazily).
            parts = mod.split(".")
            for i in range(2, len(parts) + 1):
                step = ".".join(parts[:i])
                if step in known and step != name and not name.startswith(step + "."):
                    found.add(step)

    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[: len(here) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            elif node.module and node.module.startswith(PACKAGE + "."):
                target = node.module[len(PACKAGE) + 1:]
            else:
                continue
            add(target, [a.name for a in node.names])
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith(PACKAGE + "."):
                    add(a.name[len(PACKAGE) + 1:], [])
    return found


def _graph() -> Dict[str, Set[str]]:
    mods = _modules()
    return {name: _imports(name, path, set(mods)) for name, path in mods.items()}


def _cycle(graph: Dict[str, Set[str]]) -> List[str]:
    """One import circle as a path a -> ... -> a, or [] when there is none."""
    state: Dict[str, int] = {}          # 1: on the current path, 2: done
    path: List[str] = []

    def visit(node: str) -> List[str]:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            if nxt not in state:
                found = visit(nxt)
                if found:
                    return found
        path.pop()
        state[node] = 2
        return []

    for node in sorted(graph):
        if node not in state:
            found = visit(node)
            if found:
                return found
    return []


def test_the_graph_sees_the_known_imports():
    # Guards the parser itself: a graph that saw nothing would pass every rule below.
    graph = _graph()
    assert "emulator.hat" in graph["emulator.api"]
    assert {"emulator.ports.port", "emulator.motor.controller",
            "emulator.commands.dispatch"} <= graph["emulator.hat"]
    assert "emulator.services" in graph["emulator.ports.port"]
    assert {"emulator.ports.device_conversation", "emulator.ports.device_uart",
            "emulator.ports.mode_store"} <= graph["emulator.ports.port"]
    assert "emulator.ports.lpf2" in graph["emulator.devices.active"]       # from ..ports import lpf2
    assert "emulator.devices" in graph["emulator.commands.listing"]      # ..devices.info runs devices/


def test_a_typing_only_import_of_hat_counts(tmp_path):
    # The rule covers imports under TYPE_CHECKING and inside functions, relative and absolute.
    planted = tmp_path / "part.py"
    planted.write_text(
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n"
        "    from .hat import Hat\n"
        "def f():\n"
        "    from buildhat_conformance.emulator import ports\n",
        encoding="utf-8")
    known = {"emulator", "emulator.hat", "emulator.ports", "emulator.part"}
    assert _imports("emulator.part", planted, known) == {"emulator.hat", "emulator.ports"}


def test_cycle_finder_finds_a_planted_circle():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) == []


def test_no_import_circle_in_the_emulator():
    cycle = _cycle(_graph())
    assert not cycle, "import circle: " + " -> ".join(cycle)


def test_only_the_composition_roots_users_import_hat():
    offenders = sorted(name for name, deps in _graph().items()
                       if HAT in deps and not name.startswith(HAT_USERS))
    assert not offenders, f"{offenders} import emulator/hat.py; use the Protocols of emulator/services.py"
