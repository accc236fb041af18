"""The C stand-in's own source (sil/standin/, sil/README.md): it compiles without a warning under
-Wall -Wextra, no file calls back into a file that calls it (the model reaches the frame transport and
the peripherals only through the interfaces it is given), and each definition names its parameters as
its header declares them."""
from __future__ import annotations

import graphlib
import re
import shutil
import subprocess
from pathlib import Path
from typing import Dict, List, Set

import pytest
from repo_paths import REPO

STANDIN = REPO / "sil" / "standin"
SOURCES = sorted(STANDIN.glob("*.c"))


def _compiler() -> str:
    cc = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if cc is None or shutil.which("nm") is None:
        pytest.skip("no C compiler or nm on this machine")
    return cc


@pytest.fixture(scope="module")
def objects(tmp_path_factory) -> Dict[str, Path]:
    """Each stand-in file compiled as `sil build` compiles it, warnings made errors."""
    cc, folder = _compiler(), tmp_path_factory.mktemp("standin")
    out = {}
    for src in SOURCES:
        obj = folder / f"{src.stem}.o"
        flags = ["-std=gnu11", "-O1", "-Wall", "-Wextra", "-Werror",
                 "-I", str(STANDIN / "include"), "-I", str(STANDIN)]
        done = subprocess.run([cc, *flags, "-c", str(src), "-o", str(obj)], capture_output=True, text=True)
        assert done.returncode == 0, f"{src.name}: {done.stderr}"
        out[src.name] = obj
    return out


def _symbols(obj: Path, which: str) -> Set[str]:
    text = subprocess.run(["nm", which, str(obj)], capture_output=True, text=True, check=True).stdout
    return {line.split()[-1] for line in text.splitlines() if line.strip()}


def _calls(objects: Dict[str, Path]) -> Dict[str, Set[str]]:
    """For each file, the other stand-in files whose functions or data it names."""
    defined = {name: _symbols(obj, "--defined-only") for name, obj in objects.items()}
    owner = {symbol: name for name, symbols in defined.items() for symbol in symbols}
    return {name: {owner[s] for s in _symbols(obj, "--undefined-only") if s in owner and owner[s] != name}
            for name, obj in objects.items()}


def _a_circle(calls: Dict[str, Set[str]]) -> List[str]:
    """A chain of files that comes back to its first one (empty: none)."""
    try:
        graphlib.TopologicalSorter(calls).prepare()
    except graphlib.CycleError as circle:
        return list(circle.args[1])
    return []


def test_no_file_of_the_stand_in_calls_back_into_one_that_calls_it(objects):
    calls = _calls(objects)
    assert _a_circle(calls) == [], " -> ".join(_a_circle(calls))
    # the model names neither the transport nor power-on: it reaches them through the interfaces
    model = {"machine.c", "uart.c", "pio.c", "gpio.c", "i2c.c", "adc.c", "clocks.c", "wire.c", "board.c"}
    assert not {callee for name in model for callee in calls[name]} & {"frame_transport.c", "power_on.c"}
    assert calls["machine.c"] == set()


def test_the_circle_check_sees_a_circle():
    circle = _a_circle({"a.c": {"b.c"}, "b.c": {"c.c"}, "c.c": {"a.c"}, "d.c": {"a.c"}})
    assert sorted(circle[:-1]) == ["a.c", "b.c", "c.c"] and circle[0] == circle[-1]
    assert _a_circle({"a.c": {"b.c"}, "b.c": set()}) == []


_PROTOTYPE = re.compile(r"^[\w \*]*?\b(\w+)\(([^;{)]*)\)\s*;", re.M)
_DEFINITION = re.compile(r"^[\w \*]*?\b(\w+)\(([^;{)]*)\)\s*\{", re.M)


def _parameter_names(params: str) -> List[str]:
    params = " ".join(params.split())
    if params in ("", "void"):
        return []
    return [re.findall(r"(\w+)\s*(?:\[\w*\])?$", p.strip())[0] for p in params.split(",")]


def test_each_definition_names_its_parameters_as_its_header_does():
    headers = [*STANDIN.glob("*.h"), *(STANDIN / "include").glob("*.h")]
    declared = {m.group(1): _parameter_names(m.group(2))
                for h in headers for m in _PROTOTYPE.finditer(h.read_text(encoding="utf-8"))}
    assert {"pio_sm_put", "gpio_put", "sil_pio_port_bytes", "sil_machine_power_on"} <= set(declared)
    differ = [(src.name, m.group(1), declared[m.group(1)], _parameter_names(m.group(2)))
              for src in SOURCES for m in _DEFINITION.finditer(src.read_text(encoding="utf-8"))
              if m.group(1) in declared and declared[m.group(1)] != _parameter_names(m.group(2))]
    assert differ == []
