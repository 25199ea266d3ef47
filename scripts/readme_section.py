#!/usr/bin/env python3
"""readme_section.py PAGE NAME FILE [DEMOTE]: replaces the text between the
lines <!-- NAME:begin --> and <!-- NAME:end --> of PAGE with FILE's contents,
its Markdown headings moved DEMOTE levels down (default 0): make docs puts the
latest results of make compare and make bench into docs/studies.md and
docs/performance.md this way. PAGE is rewritten atomically; a missing marker
is an error.
"""
import os
import sys


def main():
    if len(sys.argv) not in (4, 5):
        sys.exit(__doc__)
    readme, name, path = sys.argv[1:4]
    demote = int(sys.argv[4]) if len(sys.argv) == 5 else 0
    begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
    with open(readme) as f:
        text = f.read()
    if text.count(begin) != 1 or text.count(end) != 1 or text.index(begin) > text.index(end):
        sys.exit(f"readme_section.py: {readme} has no single '{begin}' ... '{end}' pair")
    with open(path) as f:
        lines = f.read().strip("\n").split("\n")
    body = "\n".join("#" * demote + l if l.startswith("#") else l for l in lines)
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    tmp = readme + ".tmp"
    with open(tmp, "w") as f:
        f.write(f"{head}{begin}\n{body}\n{end}{tail}")
    os.replace(tmp, readme)


if __name__ == "__main__":
    main()
