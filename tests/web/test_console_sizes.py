"""The console's modules keep to the house rule: no function over 60 lines in web/*.js (the
page's start, app.js ``main()``, is a list of small steps)."""

from __future__ import annotations

from pathlib import Path

from tests.web.jssource import functions

WEB = Path(__file__).resolve().parents[2] / "web"
MAX_LINES = 60


def test_no_function_over_60_lines():
    long = [f"{p.name}:{f.start} {f.name} ({f.lines} lines)"
            for p in sorted(WEB.glob("*.js")) for f in functions(p) if f.lines > MAX_LINES]
    assert long == []


def test_main_is_short():
    (main,) = [f for f in functions(WEB / "app.js") if f.name == "main"]
    assert main.lines <= MAX_LINES


def test_the_size_check_measures_every_kind_of_function(tmp_path):
    """The check itself: declarations, methods, getters and arrows are measured from their
    head to their closing brace; blocks, objects and classes are not functions."""
    module = tmp_path / "module.js"
    module.write_text(
        "function outer(a,\n"          # 1
        "  b) {\n"                     # 2
        "  if (a) {\n"                 # 3
        "    return { x: '}' };\n"     # 4
        "  }\n"                        # 5
        "  const inner = (c) => {\n"   # 6
        "    return /}/.test(c);\n"    # 7
        "  };\n"                       # 8
        "}\n"                          # 9
        "class Panel {\n"              # 10
        "  get name() {\n"             # 11
        "    return `${'{'}`;\n"       # 12
        "  }\n"                        # 13
        "}\n")                         # 14
    assert sorted((f.name, f.start, f.end) for f in functions(module)) == [
        ("inner", 6, 8), ("name", 11, 13), ("outer", 1, 9)]
