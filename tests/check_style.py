#!/usr/bin/env python3
"""The tree follows .clang-format, and no line of C or C++ is longer than 120 characters.

Every *.c, *.h and *.cpp under the source folders is given to `clang-format --dry-run --Werror`
(the version Debian 12 ships, 14; another version may format a few constructs differently: the
check is skipped, exit 77, when clang-format is absent). `NOLINT` marks are allowed only because
.clang-tidy configures the linter they silence.
Usage: check_style.py SOURCE_DIR
"""
import pathlib
import shutil
import subprocess
import sys

FOLDERS = ["lib", "verify", "fuzz", "studies", "peers", "cmd", "python", "bench", "tests", "examples"]

root = pathlib.Path(sys.argv[1]).resolve()
files = sorted(p for folder in FOLDERS for p in (root / folder).rglob("*") if p.suffix in (".c", ".h", ".cpp"))
if not files:
    sys.exit(f"{root}: no C or C++ files under {', '.join(FOLDERS)}")
bad = []
for path in files:
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if len(line) > 120:
            bad.append(f"{path.relative_to(root)}:{number}: {len(line)} characters (at most 120)")
if not (root / ".clang-tidy").is_file() and any("NOLINT" in p.read_text(encoding="utf-8") for p in files):
    bad.append("NOLINT marks without a .clang-tidy that configures the linter")
clang_format = shutil.which("clang-format")
if clang_format is None:
    print("\n".join(bad) if bad else f"{len(files)} files within 120 characters; clang-format absent: not run")
    sys.exit(1 if bad else 77)
run = subprocess.run([clang_format, "--dry-run", "--Werror", f"--style=file:{root / '.clang-format'}",
                      *map(str, files)], capture_output=True, text=True)
if run.returncode != 0:
    unformatted = sorted({line.split(":")[0] for line in run.stderr.splitlines() if ": error:" in line})
    bad += [f"{name}: not as .clang-format says (clang-format -i {name})" for name in unformatted]
print("\n".join(bad) if bad else f"{len(files)} files formatted as .clang-format says, lines within 120 characters")
sys.exit(1 if bad else 0)
