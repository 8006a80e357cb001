#!/usr/bin/env python3
"""Lists C++ source files over the line limit and functions over the body limit.

The project's rule is one idea per file: no source file over 400 lines and no function over 80.
This is a brace-matching scan, not a parser: comments, string and character literals and
preprocessor lines are blanked, then every `{` at namespace or class scope is classified by the
text before it (a parameter list's `)` plus qualifiers or a constructor's initialiser list makes
a function; `namespace`, `class`, `struct`, `union`, `enum` make a scope whose contents are
scanned in turn). Lambdas and local classes count towards the function that holds them; a
test body (TEST(...) { ... }) counts as a function. A function's length is its lines from the
opening to the closing brace.

usage: scripts/check_sizes.py [--max-file 400] [--max-function 80] [paths...]
Exits 1 when anything is over a limit, so it can run as a check.
"""
import argparse
import os
import re
import sys

EXTENSIONS = (".cpp", ".hpp", ".h", ".cc")
DEFAULT_PATHS = ["packages", "src", "bench", "test"]

_RAW_STRING = re.compile(r'R"([^(\s]*)\((.*?)\)\1"', re.S)
_TOKEN = re.compile(r'//[^\n]*|/\*.*?\*/|"(?:\\.|[^"\\\n])*"|\'(?:\\.|[^\'\\\n])*\'', re.S)
_FUNCTION_END = re.compile(
    r"\)\s*(?:const|override|final|noexcept(?:\([^()]*\))?|mutable|&&|&|->\s*[\w:<>,\s*&]+|\s)*$")
_INITIALISER_LIST = re.compile(r"\)\s*(?:noexcept\s*)?:(?!:)")
_SCOPE = re.compile(r"\b(?:namespace|class|struct|union|enum)\b")
_NAME = re.compile(r"(~?[A-Za-z_][\w:]*(?:<[^<>()]*>)?)\s*\(")


def _blank(match):
    """Keeps a literal's or comment's newlines (line numbers stay right), blanks the rest."""
    return re.sub(r"[^\n]", " ", match.group(0))


def strip(text):
    text = _RAW_STRING.sub(_blank, text)
    text = _TOKEN.sub(_blank, text)
    return "\n".join("" if line.lstrip().startswith("#") else line for line in text.split("\n"))


def classify(header):
    """'function', 'scope' or 'other' for the text before a `{` at namespace or class scope."""
    head = " ".join(header.split())
    if re.search(r"(?:^|[\s=(,])\[[^\]]*\]\s*(?:\([^()]*\))?[^=;]*$", head) and "=" in head:
        return "function"  # a lambda assigned at namespace scope
    if _FUNCTION_END.search(head):
        return "function"
    if _INITIALISER_LIST.search(head) and (head.endswith(")") or head.endswith("}")):
        return "function"
    if _SCOPE.search(head):
        return "scope"
    return "other"


def function_name(header):
    head = " ".join(header.split())
    head = re.sub(r"^template\s*<[^>]*>\s*", "", head)
    match = _NAME.search(head)
    return match.group(1) if match else head[-40:]


def scan_functions(text):
    """(name, first line, last line) of every function body at namespace or class scope."""
    stack = []  # kinds of the open braces: 'scope', 'function', 'other'
    header = []
    found = []
    line = 1
    opened_at = None
    name = None
    other_depth = 0  # braces of an initialiser at scope level, part of the next header
    for ch in text:
        if ch == "\n":
            line += 1
        in_function = "function" in stack
        if in_function:
            if ch == "{":
                stack.append("other")
            elif ch == "}":
                kind = stack.pop()
                if kind == "function":
                    found.append((name, opened_at, line))
            continue
        if other_depth:
            header.append(ch)
            if ch == "{":
                other_depth += 1
            elif ch == "}":
                other_depth -= 1
            continue
        if ch == "{":
            text_before = "".join(header)
            kind = classify(text_before)
            if kind == "other":
                header.append(ch)
                other_depth = 1
                continue
            stack.append(kind)
            if kind == "function":
                opened_at, name = line, function_name(text_before)
            header = []
        elif ch == "}":
            if stack:
                stack.pop()
            header = []
        elif ch == ";":
            header = []
        else:
            header.append(ch)
    return found


def source_files(paths):
    for root_path in paths:
        if os.path.isfile(root_path):
            yield root_path
            continue
        for root, dirs, files in os.walk(root_path):
            dirs[:] = sorted(d for d in dirs if d not in ("build", ".git", "data"))
            for name in sorted(files):
                if name.endswith(EXTENSIONS):
                    yield os.path.join(root, name)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--max-file", type=int, default=400)
    parser.add_argument("--max-function", type=int, default=80)
    parser.add_argument("paths", nargs="*", default=DEFAULT_PATHS)
    args = parser.parse_args()
    long_files, long_functions = [], []
    for path in source_files(args.paths):
        with open(path, encoding="utf-8", errors="replace") as stream:
            text = stream.read()
        lines = text.count("\n") + (0 if text.endswith("\n") else 1)
        if lines > args.max_file:
            long_files.append((lines, path))
        for name, first, last in scan_functions(strip(text)):
            if last - first + 1 > args.max_function:
                long_functions.append((last - first + 1, path, first, name))
    for lines, path in sorted(long_files, reverse=True):
        print(f"file     {lines:5d} lines  {path}")
    for lines, path, first, name in sorted(long_functions, reverse=True):
        print(f"function {lines:5d} lines  {path}:{first}  {name}")
    if not long_files and not long_functions:
        print(f"no file over {args.max_file} lines, no function over {args.max_function}")
    return 1 if long_files or long_functions else 0


if __name__ == "__main__":
    sys.exit(main())
