#!/usr/bin/env python3
"""docs/spec/ ships copies of the shared specs: each must equal ../shared/spec/NAME byte for byte.

Exits 77 (ctest: skipped) when the shared folder is not beside the clone.
Usage: check_specs.py SOURCE_DIR
"""
import pathlib
import sys

root = pathlib.Path(sys.argv[1]).resolve()
shared = root.parent / "shared" / "spec"
if not shared.is_dir():
    print(f"no {shared}: nothing to compare")
    sys.exit(77)
specs = sorted(shared.glob("*.md"))
bad = []
for spec in specs:
    copy = root / "docs" / "spec" / spec.name
    if not copy.exists():
        bad.append(f"docs/spec/{spec.name} is missing (copy {spec})")
    elif copy.read_bytes() != spec.read_bytes():
        bad.append(f"docs/spec/{spec.name} differs from {spec}")
print("\n".join(bad) if bad else f"{len(specs)} specs identical to {shared}")
sys.exit(1 if bad or not specs else 0)
