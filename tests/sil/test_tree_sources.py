"""sil/tree_sources.py: which C files make the firmware, in small trees of the test's own."""
from buildhat_conformance.sil.tree_sources import defines_main, plan_sources

MAIN = "#include \"pico/stdlib.h\"\nint main(void)\n{\n  return 0;\n}\n"


def tree(tmp_path, files, cmake=None):
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    if cmake is not None:
        (tmp_path / "CMakeLists.txt").write_text(cmake)
    return tmp_path


def names(paths):
    return [p.name for p in paths]


def test_the_executable_that_becomes_a_chip_image_is_the_firmware(tmp_path):
    t = tree(tmp_path, {"main.c": MAIN, "test.c": MAIN, "util.c": "int u;\n", "scratch.c": "int s;\n"},
             "add_executable(test test.c util.c)\ntarget_link_libraries(test pico_stdlib)\n"
             "project(main)\nadd_executable(main main.c util.c)\ntarget_link_libraries(main pico_stdlib)\n"
             "pico_add_extra_outputs(${PROJECT_NAME})\n")
    plan = plan_sources(t)
    assert names(plan.sources) == ["main.c", "util.c"] and plan.clash == []
    assert names(plan.left_out) == ["scratch.c", "test.c"]
    assert plan.left_out_line() == ("left out: scratch.c, test.c (not in CMakeLists.txt's "
                                    "add_executable(main) (the firmware of its 2 executables))")


def test_the_one_linked_with_the_sdk_before_a_host_tool(tmp_path):
    t = tree(tmp_path, {"main.c": MAIN, "gen.c": MAIN},
             "add_executable(gen gen.c)\nadd_executable(fw main.c)\ntarget_link_libraries(fw pico_stdlib)\n")
    assert names(plan_sources(t).sources) == ["main.c"]


def test_without_a_cmakelists_every_c_file_and_the_clash_named(tmp_path):
    t = tree(tmp_path, {"main.c": MAIN, "test-send.c": MAIN, "ports.c": "void f(void) { /* main(); */ }\n"})
    plan = plan_sources(t)
    assert names(plan.sources) == ["main.c", "ports.c", "test-send.c"] and plan.left_out == []
    assert names(plan.clash) == ["main.c", "test-send.c"]
    assert plan.clash_line().startswith("2 files define main(): main.c, test-send.c; ")


def test_an_unusable_cmakelists_falls_back_and_says_why(tmp_path):
    t = tree(tmp_path, {"main.c": MAIN, "ports.c": "int p;\n"}, "cmake_minimum_required(VERSION 3.13)\n")
    plan = plan_sources(t)
    assert names(plan.sources) == ["main.c", "ports.c"]
    assert plan.said() == ["CMakeLists.txt has no add_executable: building every C file of the folder"]
    (tmp_path / "b").mkdir()
    t2 = tree(tmp_path / "b", {"main.c": MAIN}, "add_executable(main elsewhere.c\n")
    assert plan_sources(t2).said() == ["CMakeLists.txt unreadable (line 1: add_executable( is never closed): "
                                       "building every C file of the folder"]


def test_a_named_file_missing_from_the_tree_is_said(tmp_path):
    t = tree(tmp_path, {"main.c": MAIN}, "add_executable(main main.c gone.c ${SDK}/x.c)\n")
    plan = plan_sources(t)
    assert names(plan.sources) == ["main.c"]
    assert plan.said() == ["not taken: gone.c (not in the tree), ${SDK}/x.c"]


def test_main_is_a_definition_at_the_start_of_a_line(tmp_path):
    for text, defines in [("int main(void) {}", True), ("void main ()\n{}", True),
                          ("int x = main(1);", False), ("// int main is elsewhere", False),
                          ("int mainloop(void) {}", False)]:
        (tmp_path / "x.c").write_text(text)
        assert defines_main(tmp_path / "x.c") == defines, text
