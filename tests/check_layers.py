#!/usr/bin/env python3
"""Fails when a file includes from a layer above its own.

The layers, bottom to top: lib (rayproof/core) <- verify <- fuzz <- studies <- peers <- cmd, with
python/ (the Python module, beside cmd),
bench/, tests/ and the libFuzzer harnesses (fuzz/libfuzzer/, programs that feed every
layer's readers, as tests do) on top. A header's path names its layer (rayproof/<layer>/...), so the rule
is checked on the include lines alone. Usage: check_layers.py SOURCE_DIR
"""
import pathlib
import re
import sys

ORDER = ["core", "verify", "fuzz", "studies", "peers", "cmd", "top"]
FOLDER_LAYER = {"lib": "core", "verify": "verify", "fuzz": "fuzz", "studies": "studies", "peers": "peers",
                "cmd": "cmd", "python": "top", "bench": "top", "tests": "top", "examples": "top"}
INCLUDE = re.compile(r'^\s*#\s*include\s+"rayproof/([a-z]+)/')


def main(root: pathlib.Path) -> int:
    bad = []
    for folder, layer in FOLDER_LAYER.items():
        for path in sorted((root / folder).rglob("*")):
            if path.suffix not in (".h", ".cpp", ".hpp", ".cc") or "build" in path.parts:
                continue
            file_layer = "top" if folder == "fuzz" and "libfuzzer" in path.parts else layer
            for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
                m = INCLUDE.match(line)
                if not m:
                    continue
                target = m.group(1)
                if target not in ORDER:
                    bad.append(f"{path.relative_to(root)}:{number}: unknown layer rayproof/{target}/")
                elif ORDER.index(target) > ORDER.index(file_layer):
                    bad.append(f"{path.relative_to(root)}:{number}: {file_layer} includes rayproof/{target}/, a layer above it")
    for b in bad:
        print(b)
    print(f"layers: {len(bad)} upward includes")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(pathlib.Path(sys.argv[1])))
