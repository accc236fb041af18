"""sil/cmake_sources.py: what a CMakeLists.txt says an executable is made of, in the layouts CMake
files of different years use. The expected lists are read off each test's own CMake text."""
import pathlib

import pytest
from shared_material import need_shared

from buildhat_conformance.sil.cmake_sources import CMakeError, read_targets

TREE = pathlib.Path("/fw")


def targets(text, tree=TREE):
    return {t.name: t for t in read_targets(text, tree)}


def test_the_r7_trees_own_file():
    tree = need_shared("firmware", "firmware-pico-1737564117", what="a firmware tree")
    main = targets((tree / "CMakeLists.txt").read_text(), tree)["main"]
    assert main.sources == ["main.c", "control.c", "command.c", "debug.c", "device.c", "hardware.c",
                            "ioconv.c", "message.c", "ports.c", "pwm_pid.c", "timer.c"]
    assert main.kind == "executable" and main.sdk_outputs and main.unresolved == []
    assert main.links == ["pico_stdlib", "hardware_adc", "hardware_i2c", "hardware_pio"]


def test_comments_line_breaks_and_quotes():
    text = """
# add_executable(old old.c)   a comment that looks like a command
#[[ a bracket comment
add_executable(gone gone.c)
]]
add_executable(main main.c   # the entry point
    "ports.c" command.c) # trailing
add_executable(main2 [[bracket.c]])
"""
    got = targets(text)
    assert list(got) == ["main", "main2"]
    assert got["main"].sources == ["main.c", "ports.c", "command.c"]
    assert got["main2"].sources == ["bracket.c"]


def test_variables_lists_and_target_sources():
    text = """
project(hat C)
set(CORE control.c ioconv.c)
set(EXTRA "debug.c;device.c")
list(APPEND CORE timer.c)
set(MAIN_SRC main.c CACHE STRING "the entry")
add_executable(${PROJECT_NAME} ${MAIN_SRC} ${CORE})
target_sources(${PROJECT_NAME} PRIVATE ${CMAKE_CURRENT_LIST_DIR}/ports.c PUBLIC ${EXTRA})
"""
    hat = targets(text)["hat"]
    # a quoted list stays one argument in set() and is split when used unquoted
    assert hat.sources == ["main.c", "control.c", "ioconv.c", "timer.c", "ports.c", "debug.c", "device.c"]


def test_nested_variables_and_case_of_commands():
    text = """
SET(which A)
Set(SRC_A a.c)
ADD_EXECUTABLE(fw ${SRC_${which}} EXCLUDE_FROM_ALL)
"""
    assert targets(text)["fw"].sources == ["a.c"]


def test_definitions_and_include_folders():
    text = """
add_compile_definitions(BOARD=2)
add_definitions(-DOLD_STYLE -Wall)
include_directories(${CMAKE_CURRENT_SOURCE_DIR}/include)
add_executable(main main.c)
target_compile_definitions(main PRIVATE PICO_DEFAULT_UART=0 "NAME=\\"hat\\"")
target_include_directories(main PUBLIC lib SYSTEM ${PICO_SDK_PATH}/src)
"""
    main = targets(text)["main"]
    assert main.definitions == ["BOARD=2", "OLD_STYLE", "PICO_DEFAULT_UART=0", 'NAME="hat"']
    assert main.include_dirs == ["include", "lib"]
    assert main.unresolved == ["${PICO_SDK_PATH}/src"]


def test_what_needs_a_real_configure_is_set_aside_not_guessed():
    text = """
add_executable(main main.c ${PICO_SDK_PATH}/lib/x.c $<$<CONFIG:Debug>:debug.c> /elsewhere/y.c)
"""
    main = targets(text)["main"]
    assert main.sources == ["main.c"]
    assert main.unresolved == ["${PICO_SDK_PATH}/lib/x.c", "$<$<CONFIG:Debug>:debug.c>", "/elsewhere/y.c"]


def test_several_targets_and_a_library_of_the_file_linked_in():
    text = """
add_library(protocol STATIC command.c message.c)
target_compile_definitions(protocol PUBLIC PROTO=1)
add_executable(test test.c)
add_executable(main main.c)
target_link_libraries(main protocol pico_stdlib)
add_library(ext IMPORTED)
add_executable(alias ALIAS main)
"""
    got = targets(text)
    assert [(n, t.kind) for n, t in got.items()] == [("protocol", "library"), ("test", "executable"),
                                                     ("main", "executable")]
    assert got["main"].sources == ["main.c", "command.c", "message.c"]
    assert got["main"].definitions == ["PROTO=1"]
    assert got["main"].sdk_outputs and not got["test"].sdk_outputs


def test_file_glob_in_the_tree(tmp_path):
    for name in ("a.c", "b.c", "notes.txt"):
        (tmp_path / name).write_text("")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "c.c").write_text("")
    text = """
file(GLOB SRC CONFIGURE_DEPENDS ${CMAKE_CURRENT_LIST_DIR}/*.c)
file(GLOB_RECURSE ALL *.c)
add_executable(main ${SRC})
add_executable(every ${ALL})
"""
    got = targets(text, tmp_path)
    assert got["main"].sources == ["a.c", "b.c"]
    assert got["every"].sources == ["a.c", "b.c", "sub/c.c"]


def test_an_unclosed_command_is_one_line_with_its_line_number():
    with pytest.raises(CMakeError, match=r"^line 3: add_executable\( is never closed$"):
        read_targets("project(x)\n\nadd_executable(main main.c\n", TREE)
