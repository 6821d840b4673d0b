#!/usr/bin/env python3
"""Every tool's --help (and each subcommand's) as a newcomer reads it: it exits 0, no line is wider than 120
characters (teleop::kHelpWidth, common/include/teleop/cli_help.hpp), no line of 30 characters or more is printed twice
(teleop-plot and teleop-canlog once printed their description twice), and each option that takes a value shows its
default: a CLI11 option with a number type shows `=VALUE` (teleop::StandardHelp captures every default; an empty text
default shows nothing, which is what it is), unless it is REQUIRED or its text says its default; an argparse option
with a value says "default" in its text.

  help_texts_test.py TOOL...     paths of the C++ tools and the python ones (deploy/teleop-plot, ...)
"""
import os
import re
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
from teleop_process import check, run_test  # noqa: E402

WIDTH = 120
# A CLI11 option line: "  -c,--config TEXT:FILE REQUIRED" or "  --port UINT=47300   UDP port ...".
CLI11_OPTION = re.compile(r"^  (?:-\w,)?(--[\w-]+)(?: ([A-Z][A-Z]+\S*(?: \.\.\.)?(?: REQUIRED)?))?(?:\s{2,}(.*))?$")
NUMBER_TYPE = re.compile(r"^(INT|UINT|FLOAT|NUMBER)\b")
ARGPARSE_OPTION = re.compile(r"^  (?:-\w, )?(--[\w-]+)(?: ([A-Z_]+))?(?:\s{2,}(.*))?$")


def help_text(argv):
    r = subprocess.run(argv + ["--help"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=30)
    return r.returncode, r.stdout


def option_blocks(lines, pattern):
    """(option, value type or None, its whole description) for each option line, with the description's further
    lines (more indented, not another option)."""
    out = []
    for i, line in enumerate(lines):
        m = pattern.match(line)
        if not m:
            continue
        desc = [m.group(3) or ""]
        for more in lines[i + 1:]:
            if not more.startswith("      ") or pattern.match(more):
                break
            desc.append(more.strip())
        out.append((m.group(1), m.group(2), " ".join(desc)))
    return out


def check_one(name, argv, sub, problems):
    rc, text = help_text(argv + sub)
    label = " ".join([name] + sub)
    if rc != 0:
        problems.append(f"{label} --help: exit {rc}")
        return text
    lines = text.splitlines()
    for line in lines:
        if len(line) > WIDTH:
            problems.append(f"{label} --help: a line of {len(line)} characters: {line[:60]}...")
    seen = {}
    for line in lines:
        if len(line.strip()) >= 30:
            seen[line.strip()] = seen.get(line.strip(), 0) + 1
    for line, n in seen.items():
        if n > 1:
            problems.append(f"{label} --help: printed {n} times: {line[:60]}...")
    if text.startswith("usage:"):  # argparse
        for opt, value, desc in option_blocks(lines, ARGPARSE_OPTION):
            if value and opt not in ("--help", "--version") and "default" not in desc:
                problems.append(f"{label} --help: {opt} {value} does not say its default")
    else:
        for opt, value, desc in option_blocks(lines, CLI11_OPTION):
            if not value or "=" in value or "REQUIRED" in value or "default" in desc:
                continue
            if NUMBER_TYPE.match(value):
                problems.append(f"{label} --help: {opt} {value} does not show its default")
    return text


def subcommands(text):
    if "\nSubcommands:\n" not in text:
        return []
    block = text.split("\nSubcommands:\n", 1)[1]
    return [m.group(1) for m in re.finditer(r"^  ([a-z][\w-]*)\s", block, re.M)]


def main():
    tools = sys.argv[1:]
    check(tools, "tools named on the command line")
    problems, checked = [], 0
    for tool in tools:
        name = os.path.basename(tool)
        argv = [sys.executable, tool] if tool.endswith(("-plot", "-canlog", "-session")) else [tool]
        text = check_one(name, argv, [], problems)
        checked += 1
        for sub in subcommands(text):
            check_one(name, argv, [sub], problems)
            checked += 1
    for p in problems:
        print(p)
    check(not problems, f"{checked} help texts of {len(tools)} tools: exit 0, lines within {WIDTH} characters, "
          f"nothing printed twice, defaults shown ({len(problems)} problems)")
    return 0


if __name__ == "__main__":
    run_test(main)
