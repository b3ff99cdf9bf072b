#!/usr/bin/env python3
"""Every deliberate bug of scripts/mutation-check.sh still applies: its anchor text is found in its
file. A mutant whose anchor has gone (the code moved, or was reformatted) is reported by the
script as NOT APPLIED, and would otherwise pass unnoticed as a kill that was never tried.
Usage: check_mutants.py SOURCE_DIR
"""
import pathlib
import re
import sys

root = pathlib.Path(sys.argv[1]).resolve()
script = (root / "scripts" / "mutation-check.sh").read_text(encoding="utf-8")
# mutate "NAME" FILE \ "FROM" "TO"   (FROM in double or single quotes, possibly on the next line)
calls = re.findall(r'^mutate "([^"]+)" (\S+) \\?\n?\s*(\'[^\']*\'|"(?:[^"\\]|\\.)*")', script, re.M)
declared = len(re.findall(r"^mutate ", script, re.M))
bad = []
if len(calls) != declared:
    bad.append(f"scripts/mutation-check.sh: {declared} mutants, {len(calls)} readable by this check")
for name, path, quoted in calls:
    anchor = quoted[1:-1].replace('\\"', '"') if quoted[0] == '"' else quoted[1:-1]
    file = root / path
    if not file.is_file():
        bad.append(f"{name}: {path} does not exist")
    elif anchor not in file.read_text(encoding="utf-8"):
        bad.append(f"{name}: its anchor is not in {path}: {anchor}")
print("\n".join(bad) if bad else f"{len(calls)} mutants, each anchor found in its file")
sys.exit(1 if bad else 0)
