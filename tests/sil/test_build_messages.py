"""sil/build_messages.py: the compiler's and linker's own cause, in one line, for what other tool
versions print than this machine's (GCC 14 and clang refuse an undeclared function; ld without line
tables). The real tools' output on this machine is tested through `sil build` in test_build.py."""
from buildhat_conformance.sil.build_messages import compile_failure, defined_in, link_failure

PORTS = "#include \"pico/stdlib.h\"\nvoid start(void)\n{\n  pio_sm_xxx(0, 1);\n}\n"


def tree(tmp_path, files):
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    return tmp_path


def test_gcc_14_and_clang_refusing_an_undeclared_sdk_function(tmp_path):
    t = tree(tmp_path, {"ports.c": PORTS})
    gcc14 = (f"{t}/ports.c: In function 'start':\n"
             f"{t}/ports.c:4:3: error: implicit declaration of function 'pio_sm_xxx'; did you mean "
             "'pio_sm_put'? [-Wimplicit-function-declaration]\n")
    clang = (f"{t}/ports.c:4:3: error: call to undeclared function 'pio_sm_xxx'; ISO C99 and later do "
             "not support implicit function declarations [-Wimplicit-function-declaration]\n")
    for stderr in (gcc14, clang):
        assert compile_failure(stderr, t, [t / "ports.c"], [], "CMakeLists.txt") == \
            "the stand-in does not model `pio_sm_xxx()`, called in ports.c:4"


def test_an_undeclared_function_the_tree_defines_in_a_left_out_file(tmp_path):
    t = tree(tmp_path, {"ports.c": PORTS, "extra.c": "int pio_sm_xxx(int a, int b)\n{\n  return a + b;\n}\n"})
    stderr = f"{t}/ports.c:4:3: error: implicit declaration of function 'pio_sm_xxx'\n"
    origin = "CMakeLists.txt's add_executable(main)"
    assert compile_failure(stderr, t, [t / "ports.c"], [t / "extra.c"], origin) == \
        "`pio_sm_xxx()`, called in ports.c:4, is defined in extra.c, which " \
        "CMakeLists.txt's add_executable(main) leaves out"


def test_a_missing_header_of_the_sdk_and_the_trees_own_error(tmp_path):
    t = tree(tmp_path, {"ports.c": PORTS})
    gcc = (f"{t}/ports.c:1:10: fatal error: hardware/dma.h: No such file or directory\n"
           "compilation terminated.\n")
    clang = f"{t}/ports.c:1:10: fatal error: 'hardware/dma.h' file not found\n"
    for stderr in (gcc, clang):
        assert compile_failure(stderr, t, [t / "ports.c"], [], "x") == \
            "the stand-in has no `hardware/dma.h`, included in ports.c:1"
    own = f"{t}/ports.c:3:1: error: expected ';' before '}}' token\n"
    assert compile_failure(own, t, [], [], "x") is None


def test_the_linker_without_line_tables_names_the_objects_sources(tmp_path):
    t = tree(tmp_path, {"main.c": "int main(void) { return 0; }\n",
                        "test-send.c": "int main(void) { return 1; }\n"})
    objects = {"fw_main.o": "main.c", "fw_test-send.o": "test-send.c"}
    stderr = ("/usr/bin/ld: /cache/ab/fw_test-send.o: in function `main':\n"
              "fw_test-send.o:(.text+0x0): multiple definition of `main'; /cache/ab/fw_main.o:(.text+0x0): "
              "first defined here\ncollect2: error: ld returned 1 exit status\n")
    assert link_failure(stderr, t, objects, [], [], "x") == \
        "multiple definition of `main': test-send.c and main.c"
    stderr = ("/usr/bin/ld: /cache/ab/fw_main.o: in function `main':\n"
              "main.c:(.text+0x12): undefined reference to `pio_sm_xxx'\n"
              "collect2: error: ld returned 1 exit status\n")
    assert link_failure(stderr, t, objects, [t / "main.c"], [], "x") == \
        "the stand-in does not model `pio_sm_xxx()`, called in main.c"


def test_another_linker_error_is_its_own_line_not_collect2(tmp_path):
    stderr = ("/usr/bin/ld: cannot find -lfoo: No such file or directory\n"
              "collect2: error: ld returned 1 exit status\n")
    assert link_failure(stderr, tmp_path, {}, [], [], "x") == "cannot find -lfoo: No such file or directory"


def test_defined_in_finds_a_body_not_a_declaration_or_a_call(tmp_path):
    t = tree(tmp_path, {"a.c": "int f(int x);\nint g(void) { return f(1); }\n",
                        "b.c": "static inline int\nf(int x)\n{\n  return x;\n}\n",
                        "c.c": "int f (int x) { return x; }\n"})
    assert [p.name for p in defined_in("f", [t / "a.c", t / "b.c", t / "c.c"])] == ["b.c", "c.c"]


def test_a_header_of_the_tree_in_a_folder_no_include_folder_names(tmp_path):
    t = tree(tmp_path, {"main.c": "#include \"timer.h\"\n"})
    (t / "inc").mkdir()
    (t / "inc" / "timer.h").write_text("")
    stderr = f"{t}/main.c:1:10: fatal error: timer.h: No such file or directory\n"
    assert compile_failure(stderr, t, [], [], "x") == \
        "`timer.h`, included in main.c:1, is in inc/ of the tree, which no include folder names"
    # a header of neither the tree nor the SDK: the compiler's own line (None here)
    assert compile_failure(f"{t}/main.c:1:10: fatal error: other.h: No such file or directory\n",
                           t, [], [], "x") is None
