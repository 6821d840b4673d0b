#!/usr/bin/env python3
"""Function bodies longer than a threshold, in lines: what issue 27's "Done when" measures (no function in
common/src/node or common/src/fieldbus over 80 lines, none in the cycle over 60).

A body's length is the count of lines from the line of its opening brace to the line of its closing brace. A brace
matcher over the source with comments, string and character literals blanked: a brace block whose header (the text
since the previous `;`, `{` or `}`) ends in a parameter list and optional qualifiers, outside any other function, is a
function; lambdas and local classes count as part of the function that holds them. No compiler needed, so it runs in
a second over the tree (clang-tidy's readability-function-size with LineThreshold gives the same list, much slower).

  deploy/lib/function_lengths.py 80 common/src/node/*.cpp common/src/node/coupling/*.cpp common/src/fieldbus/*.cpp
  deploy/lib/function_lengths.py 60 common/src/device/*/*.cpp

Prints "<lines> <file>:<line> <name>" per function over the threshold, longest first; exit 1 when there is one.
"""
import re
import sys


def blank(src):
    """`src` with comments and string/char literals replaced by spaces (newlines kept, so line numbers hold)."""
    out = []
    i, n = 0, len(src)
    while i < n:
        if src.startswith("//", i):
            j = src.find("\n", i)
            j = n if j < 0 else j
        elif src.startswith("/*", i):
            j = src.find("*/", i + 2)
            j = n if j < 0 else j + 2
        elif src.startswith('R"', i) and (i == 0 or not (src[i - 1].isalnum() or src[i - 1] == "_")):
            m = re.match(r'R"([^(]*)\(', src[i:])
            end = src.find(")" + m.group(1) + '"', i) if m else -1
            j = n if end < 0 else end + len(m.group(1)) + 2
        elif src[i] in "\"'" and not (src[i] == "'" and i > 0 and src[i - 1].isalnum()):  # 1'000 is a digit separator
            quote, j = src[i], i + 1
            while j < n and src[j] != quote:
                j += 2 if src[j] == "\\" else 1
            j += 1
        else:
            out.append(src[i])
            i += 1
            continue
        out.append(re.sub(r"[^\n]", " ", src[i:j]))
        i = j
    return "".join(out)


HEADER = re.compile(r"([~\w:<>]+)\s*\((?:.|\n)*\)\s*(?:const|noexcept|override|final|mutable|->[^{]*|\s|:[^{]*)*$")
NOT_FUNCTION = re.compile(r"\b(if|for|while|switch|catch|return|class|struct|namespace|enum|union)\b|=\s*$")


def functions(path):
    """(lines, first line, name) of every function definition in `path`."""
    text = blank(open(path, encoding="utf-8").read())
    found, stack = [], []  # stack: (is_function, brace offset, name)
    for m in re.finditer(r"[{}]", text):
        at = m.start()
        if text[at] == "{":
            start = max(text.rfind(";", 0, at), text.rfind("{", 0, at), text.rfind("}", 0, at)) + 1
            head = text[start:at].strip()
            match = HEADER.search(head)
            is_function = (not any(f for f, _, _ in stack) and match is not None and
                           not NOT_FUNCTION.search(head.split("(")[0]))
            stack.append((is_function, at, match.group(1) if is_function else ""))
        elif stack:
            is_function, open_at, name = stack.pop()
            if is_function:
                first = text.count("\n", 0, open_at) + 1
                last = text.count("\n", 0, at) + 1
                found.append((last - first + 1, first, name))
    return found


def main():
    if len(sys.argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    threshold = int(sys.argv[1])
    over = [(n, f, line, name) for f in sys.argv[2:] for n, line, name in functions(f) if n > threshold]
    for n, f, line, name in sorted(over, key=lambda x: (-x[0], x[1])):
        print(f"{n:4d} {f}:{line} {name}")
    return 1 if over else 0


if __name__ == "__main__":
    sys.exit(main())
