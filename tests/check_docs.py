#!/usr/bin/env python3
"""The front door stays short and the docs stay navigable (issue 41): README.md at most 300
lines; every page under docs/ over 200 lines (the shared specs' copies aside, which must stay
identical to the originals) has a table of contents at its top; every relative link and image
in README.md and docs/ names a file that exists, and every #anchor a heading of its page.

Usage: tests/check_docs.py SOURCE_DIR
"""
import os
import re
import sys


def anchor(heading):
    # GitHub's rule: lower case, punctuation other than - and _ dropped, spaces to hyphens.
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def main(root):
    problems = []
    readme = os.path.join(root, "README.md")
    n = len(open(readme, encoding="utf-8").read().splitlines())
    if n > 300:
        problems.append(f"README.md: {n} lines, more than 300: move reference and results to docs/")
    pages = [readme]
    for folder, _, files in os.walk(os.path.join(root, "docs")):
        pages += [os.path.join(folder, f) for f in sorted(files) if f.endswith(".md")]
    for page in pages:
        text = open(page, encoding="utf-8").read()
        rel = os.path.relpath(page, root)
        lines = text.splitlines()
        in_spec = os.sep + "spec" + os.sep in page
        if page != readme and not in_spec and len(lines) > 200 and "Contents:" not in "\n".join(lines[:12]):
            problems.append(f"{rel}: {len(lines)} lines and no table of contents ('Contents:') at its top")
        headings = {anchor(re.sub(r"^#+ ", "", l)) for l in lines if re.match(r"^#{1,6} ", l)}
        prose = re.sub(r"```.*?```", "", text, flags=re.S)  # links inside code blocks are examples
        for target in re.findall(r"\]\(([^)\s]+)\)", prose) + re.findall(r'src="([^"]+)"', prose):
            if re.match(r"^[a-z]+:", target):
                continue
            path, _, fragment = target.partition("#")
            if path:
                full = os.path.normpath(os.path.join(os.path.dirname(page), path))
                if not os.path.exists(full):
                    problems.append(f"{rel}: link to {target}: no such file")
                    continue
                if fragment and full.endswith(".md"):
                    other = open(full, encoding="utf-8").read().splitlines()
                    if fragment not in {anchor(re.sub(r"^#+ ", "", l)) for l in other if re.match(r"^#{1,6} ", l)}:
                        problems.append(f"{rel}: link to {target}: no such heading in {path}")
            elif fragment not in headings:
                problems.append(f"{rel}: link to #{fragment}: no such heading")
    for p in problems:
        print(p)
    if problems:
        sys.exit(1)
    print(f"README.md {n} lines; {len(pages)} pages, their links and contents checked")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
