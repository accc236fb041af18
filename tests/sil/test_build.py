"""``buildhat-conformance sil build``: the user's command, its cache and its one-line errors."""
import hashlib
import os
import subprocess
import sys

import pytest
from sil_support import cli, copy_tree, firmware_tree, plant  # noqa: E402

from buildhat_conformance.sil.build import standin_dir


def _digest(tree):
    h = hashlib.sha256()
    for p in sorted(tree.rglob("*")):
        if p.is_file():
            h.update(p.name.encode() + p.read_bytes())
    return h.hexdigest()


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("silcache")


def test_build_prints_one_line_caches_and_leaves_the_tree_alone(cache):
    tree = firmware_tree()
    before = _digest(tree)
    first = cli("sil", "build", str(tree), cache=cache)
    assert first.returncode == 0, first.stderr
    lines = first.stdout.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(("built: ", "up to date: ")), first.stdout
    program = lines[0].split(" -> ")[1].split(" (")[0]
    assert os.access(program, os.X_OK)
    again = cli("sil", "build", str(tree), cache=cache)
    assert again.stdout.startswith("up to date: ") and program in again.stdout
    assert _digest(tree) == before, "the build wrote into the firmware tree"


def test_a_checkout_that_contains_firmware_pico_is_found(cache, tmp_path):
    copy_tree(tmp_path / "checkout" / "firmware-pico")
    done = cli("sil", "build", str(tmp_path / "checkout"), cache=cache)
    assert done.returncode == 0, done.stderr


@pytest.mark.parametrize("what", ["missing", "empty", "file"])
def test_not_a_firmware_tree_is_one_line_exit_2(cache, tmp_path, what):
    path = tmp_path / "x"
    if what == "empty":
        path.mkdir()
    elif what == "file":
        path.write_text("int main(void){return 0;}\n")
    done = cli("sil", "build", str(path), cache=cache)
    assert done.returncode == 2
    assert done.stdout == "" and len(done.stderr.strip().splitlines()) == 1
    assert done.stderr.startswith("buildhat-conformance sil: ")


def test_a_compile_error_names_the_file_and_the_compilers_first_error(cache, tmp_path):
    tree = copy_tree(tmp_path / "broken")
    (tree / "ioconv.c").write_text("#error planted by the test\n" + (tree / "ioconv.c").read_text())
    done = cli("sil", "build", str(tree), cache=cache)
    assert done.returncode == 2
    line = done.stderr.strip()
    assert "\n" not in line and "ioconv.c" in line and "planted by the test" in line


def test_no_compiler_is_one_line_exit_2(cache, tmp_path):
    empty = tmp_path / "bin"          # a PATH with no compiler on it
    empty.mkdir()
    done = subprocess.run([sys.executable, "-m", "buildhat_conformance.cli",
                           "sil", "build", str(firmware_tree())], capture_output=True, text=True,
                          env={"PATH": str(empty), "BUILDHAT_SIL_CACHE": str(cache)})
    assert done.returncode == 2
    assert done.stderr.strip() == ("buildhat-conformance sil: no C compiler found: "
                                   "install gcc or clang (or set CC)")


def test_unknown_sanitizer_is_a_usage_error(cache):
    done = cli("sil", "build", str(firmware_tree()), "--sanitize", "thread", cache=cache)
    assert done.returncode == 2 and "unknown sanitizer 'thread'" in done.stderr


def test_the_stand_in_is_warning_free(tmp_path):
    import shutil
    cc = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if cc is None:
        pytest.skip("no C compiler on this machine")
    for src in sorted(standin_dir().glob("*.c")):
        done = subprocess.run([cc, "-std=gnu11", "-O1", "-Wall", "-Wextra", "-Werror",
                               "-I", str(standin_dir() / "include"), "-I", str(standin_dir()),
                               "-c", str(src), "-o", str(tmp_path / (src.stem + ".o"))],
                              capture_output=True, text=True)
        assert done.returncode == 0, done.stderr


# -- trees as the firmware's history has them: C files the firmware's own build leaves out ----------
TEST_PROGRAM = '#include "pico/stdlib.h"\nint main(void) {\n  stdio_init_all();\n  return 0;\n}\n'


def _with_stray_test(tmp_path, name="stray"):
    """A copy of the R7 tree with a test program of its own main() (its CMakeLists leaves it out)."""
    tree = copy_tree(tmp_path / name)
    (tree / "test.c").write_text(TEST_PROGRAM)
    return tree


def _line_of(path, text):
    return path.read_text().splitlines().index(text) + 1


def test_a_stray_test_program_the_cmakelists_leaves_out_builds_and_is_named(cache, tmp_path):
    tree = _with_stray_test(tmp_path)
    done = cli("sil", "build", str(tree), cache=cache)
    assert done.returncode == 0, done.stderr
    first, second = done.stdout.strip().splitlines()
    assert first.endswith(f"(target: sil:{tree})"), first        # the tree, not the cache path
    assert second == "left out: test.c (not in CMakeLists.txt's add_executable(main))"
    sanitized = cli("sil", "build", str(tree), "--coverage", cache=cache)
    assert sanitized.returncode == 0 and f"(target: sil:{tree}?coverage=1)" in sanitized.stdout


def test_without_the_cmakelists_the_clash_is_named(cache, tmp_path):
    tree = _with_stray_test(tmp_path)
    (tree / "CMakeLists.txt").unlink()
    done = cli("sil", "build", str(tree), cache=cache)
    assert done.returncode == 2 and done.stdout == ""
    line = done.stderr.strip()
    assert "\n" not in line and "2 files define main(): main.c, test.c" in line, line


def test_a_scratch_file_without_main_builds_without_a_cmakelists(cache, tmp_path):
    tree = copy_tree(tmp_path / "scratch")
    (tree / "CMakeLists.txt").unlink()
    (tree / "scratch.c").write_text("int scratch_value(int x)\n{\n  return x * 2;\n}\n")
    done = cli("sil", "build", str(tree), cache=cache)
    assert done.returncode == 0 and len(done.stdout.strip().splitlines()) == 1, done.stdout + done.stderr


def test_a_cmakelists_that_names_both_mains_gets_the_linkers_own_cause(cache, tmp_path):
    tree = _with_stray_test(tmp_path)
    plant(tree, "CMakeLists.txt", "  timer.c\n", "  timer.c\n  test.c\n")
    done = cli("sil", "build", str(tree), cache=cache)
    assert done.returncode == 2
    main_at = _line_of(tree / "main.c", "int main() {")     # the line where each main's code begins
    assert done.stderr.strip() == ("buildhat-conformance sil: linking: multiple definition of `main': "
                                   f"test.c:2 and main.c:{main_at}"), done.stderr


def test_a_pico_sdk_function_the_stand_in_lacks_is_named_with_its_calling_line(cache, tmp_path):
    tree = copy_tree(tmp_path / "sdk")
    call = "  pio_sm_set_enabled(pio,tsm,true);"
    plant(tree, "ports.c", call + "\n", call + "\n  pio_sm_clkdiv_restart(pio,tsm);\n")
    done = cli("sil", "build", str(tree), cache=cache)
    assert done.returncode == 2
    at = _line_of(tree / "ports.c", "  pio_sm_clkdiv_restart(pio,tsm);")
    assert done.stderr.strip() == ("buildhat-conformance sil: linking: the stand-in does not model "
                                   f"`pio_sm_clkdiv_restart()`, called in ports.c:{at}"), done.stderr


def test_a_pico_sdk_header_the_stand_in_lacks_is_named(cache, tmp_path):
    tree = copy_tree(tmp_path / "header")
    plant(tree, "ports.c", '#include "ports.h"\n', '#include "ports.h"\n#include "hardware/dma.h"\n')
    done = cli("sil", "build", str(tree), cache=cache)
    at = _line_of(tree / "ports.c", '#include "hardware/dma.h"')
    assert done.returncode == 2
    assert done.stderr.strip().endswith(f"the stand-in has no `hardware/dma.h`, included in ports.c:{at}")


def test_another_years_cmakelists_layout(cache, tmp_path):
    """Variables, comments, line breaks, target_sources, a test executable of its own, a definition the
    tree needs and a header in an include folder: only the firmware's files, built with both."""
    tree = _with_stray_test(tmp_path)
    (tree / "inc").mkdir()
    (tree / "timer.h").rename(tree / "inc" / "timer.h")
    (tree / "scratch.c").write_text("int scratch(void) { return undefined_elsewhere(); }\n")
    plant(tree, "main.c", "int main() {", "#ifndef HAT_LAYOUT_TEST\n#error needs the CMakeLists' definition\n"
                                          "#endif\nint main() {")
    (tree / "CMakeLists.txt").write_text("""\
cmake_minimum_required(VERSION 3.12)
include(pico_sdk_import.cmake)
project(buildhat C CXX ASM)
pico_sdk_init()
# the firmware's files, in two lists
set(FIRMWARE_CORE control.c command.c debug.c   # comment after files
    device.c hardware.c ioconv.c message.c)
list(APPEND FIRMWARE_CORE pwm_pid.c timer.c)
add_executable(${PROJECT_NAME}
  ${CMAKE_CURRENT_LIST_DIR}/main.c
)
target_sources(${PROJECT_NAME} PRIVATE ${FIRMWARE_CORE} ports.c)
target_compile_definitions(${PROJECT_NAME} PRIVATE HAT_LAYOUT_TEST=1)
target_include_directories(${PROJECT_NAME} PRIVATE ${CMAKE_CURRENT_LIST_DIR}/inc ${PICO_SDK_PATH}/x)
target_link_libraries(${PROJECT_NAME} pico_stdlib hardware_pio)
pico_add_extra_outputs(${PROJECT_NAME})
# a test program of its own
add_executable(test_send test.c)
target_link_libraries(test_send pico_stdlib)
""")
    done = cli("sil", "build", str(tree), cache=cache)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.strip().splitlines()
    assert lines[1] == ("left out: scratch.c, test.c (not in CMakeLists.txt's add_executable(buildhat) "
                        "(the firmware of its 2 executables))"), lines
    assert lines[2] == "not taken: ${PICO_SDK_PATH}/x", lines


def test_the_cmakelists_is_part_of_the_cache_key(cache, tmp_path):
    tree = _with_stray_test(tmp_path)
    (tree / "extra.c").write_text("int extra_value = 7;\n")
    first = cli("sil", "build", str(tree), cache=cache)
    assert first.returncode == 0 and "left out: extra.c, test.c " in first.stdout, first.stdout + first.stderr
    plant(tree, "CMakeLists.txt", "  timer.c\n", "  timer.c\n  extra.c\n")
    second = cli("sil", "build", str(tree), cache=cache)
    assert second.stdout.startswith("built: "), second.stdout + second.stderr     # not the cached one
    assert "left out: test.c " in second.stdout
    program = lambda done: done.stdout.split(" -> ")[1].split(" (")[0]   # noqa: E731
    assert program(first) != program(second)
