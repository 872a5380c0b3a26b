"""A small reader of the console's ES modules for the source checks of tests/web: the string
literals of a file (comments and regular expressions skipped) and the length of its functions.

Not a JavaScript parser: it knows strings, template literals (with nested ``${}``), comments
and regular-expression literals well enough for the plain code of ``web/*.js``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

# After one of these a '/' starts a regular expression, not a division.
_REGEX_AFTER = set("(,=:[!&|?{};+-*%<>~^") | {""}
_REGEX_KEYWORDS = {"return", "typeof", "case", "of", "in", "delete", "void", "throw", "else"}
_CONTROL = {"if", "for", "while", "switch", "catch", "with"}


@dataclass
class Literal:
    """A string literal: its text (a template's ``${…}`` parts kept as written) and line."""

    text: str
    line: int


@dataclass
class Function:
    """A function body: its name as far as the reader can tell, first and last line."""

    name: str
    start: int
    end: int

    @property
    def lines(self) -> int:
        return self.end - self.start + 1


class _Scanner:
    def __init__(self, source: str):
        self.src = source
        self.i = 0
        self.literals: list[Literal] = []
        # the code with every string, comment and regex blanked (newlines kept)
        self.code: list[str] = []
        self.last = ""  # the last significant code token's end ('' at the start)

    def line(self, at: int) -> int:
        return self.src.count("\n", 0, at) + 1

    def blank(self, text: str) -> None:
        self.code.append(re.sub(r"[^\n]", " ", text))

    def run(self, stop_at_brace: bool = False) -> None:
        depth = 0
        src = self.src
        while self.i < len(src):
            c = src[self.i]
            two = src[self.i:self.i + 2]
            if two == "//":
                end = src.find("\n", self.i)
                end = len(src) if end < 0 else end
                self.blank(src[self.i:end])
                self.i = end
            elif two == "/*":
                end = src.find("*/", self.i + 2)
                end = len(src) if end < 0 else end + 2
                self.blank(src[self.i:end])
                self.i = end
            elif c in "'\"`":
                self.string(c)
            elif c == "/" and self.regex_may_start():
                self.regex()
            else:
                if stop_at_brace:
                    if c == "{":
                        depth += 1
                    elif c == "}":
                        if depth == 0:
                            return
                        depth -= 1
                self.code.append(c)
                if not c.isspace():
                    self.last = (self.last + c)[-12:] if (c.isalnum() or c in "_$") else c
                self.i += 1

    def regex_may_start(self) -> bool:
        last = self.last
        if last[-1:].isalnum() or last[-1:] in ("_", "$"):
            word = re.search(r"[A-Za-z_$][\w$]*$", last)
            return bool(word) and word.group(0) in _REGEX_KEYWORDS
        return last[-1:] in _REGEX_AFTER

    def string(self, quote: str) -> None:
        """A '…', "…" or `…` literal; a template's ``${…}`` is read as code (its own
        literals found too) and kept as written in the template's text."""
        start = self.i
        j = self.i + 1
        text = []
        while j < len(self.src) and self.src[j] != quote:
            if self.src[j] == "\\":
                text.append(self.src[j:j + 2])
                j += 2
            elif quote == "`" and self.src[j:j + 2] == "${":
                inner = _Scanner(self.src)
                inner.i = j + 2
                inner.run(stop_at_brace=True)
                self.literals.extend(inner.literals)
                text.append(self.src[j:inner.i + 1])
                j = inner.i + 1
            else:
                text.append(self.src[j])
                j += 1
        self.i = j + 1
        self.literals.append(Literal("".join(text), self.line(start)))
        self.blank(self.src[start:self.i])
        self.last = "s"

    def regex(self) -> None:
        start = self.i
        j = self.i + 1
        in_class = False
        while j < len(self.src) and self.src[j] != "\n":
            c = self.src[j]
            if c == "\\":
                j += 2
                continue
            if c == "[":
                in_class = True
            elif c == "]":
                in_class = False
            elif c == "/" and not in_class:
                break
            j += 1
        j += 1
        while j < len(self.src) and self.src[j].isalpha():
            j += 1
        self.i = j
        self.blank(self.src[start:j])
        self.last = "s"


def _scan(path: Path) -> _Scanner:
    scanner = _Scanner(path.read_text())
    scanner.run()
    return scanner


def string_literals(path: Path) -> list[Literal]:
    """Every string and template literal of a module, outside comments and regexes."""
    return _scan(path).literals


def functions(path: Path) -> list[Function]:
    """Every function body of a module (declarations, methods, arrows with a block), nested
    ones included, each from the line of its head to the line of its closing brace."""
    code = "".join(_scan(path).code)
    found = []
    stack: list[tuple[int, str | None]] = []
    for i, c in enumerate(code):
        if c == "{":
            stack.append((i, _function_name(code, i)))
        elif c == "}" and stack:
            start, name = stack.pop()
            if name is not None:
                head = _head_start(code, start)
                found.append(Function(name, code.count("\n", 0, head) + 1,
                                      code.count("\n", 0, i) + 1))
    return found


def _head_start(code: str, brace: int) -> int:
    """Where the head of the function whose body opens at ``brace`` starts (its line)."""
    before = code[:brace].rstrip()
    if before.endswith("=>"):
        before = before[:-2].rstrip()
    if before.endswith(")"):
        return _matching_paren(code, len(before) - 1)
    return len(before)


def _matching_paren(code: str, close: int) -> int:
    depth = 0
    for k in range(close, -1, -1):
        if code[k] == ")":
            depth += 1
        elif code[k] == "(":
            depth -= 1
            if depth == 0:
                return k
    return close


def _function_name(code: str, brace: int) -> str | None:
    """The name of the function whose body opens at ``brace``; None when it opens a block,
    an object or a class."""
    before = code[:brace].rstrip()
    if before.endswith("=>"):
        head = before[:-2].rstrip()
        if head.endswith(")"):
            head = head[:_matching_paren(code, len(head) - 1)].rstrip()
        else:
            head = re.sub(r"[\w$]+$", "", head).rstrip()
        name = re.search(r"([\w$.]+)\s*[=:]\s*(async\s*)?$", head)
        return name.group(1) if name else "(arrow)"
    if not before.endswith(")"):
        return None
    head = before[:_matching_paren(code, len(before) - 1)].rstrip()
    word = re.search(r"([\w$]+)$", head)
    if not word:
        return None
    name = word.group(1)
    if name in _CONTROL:
        return None
    if name == "function":
        assigned = re.search(r"([\w$.]+)\s*[=:]\s*(async\s+)?function$", head)
        return assigned.group(1) if assigned else "(function)"
    return name
