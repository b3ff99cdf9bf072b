#!/bin/sh
# The installed package works for an outside project: install this build to a temporary prefix,
# then configure, build and run examples/consumer (its own GoogleTest suite using rayproof::audit
# and the matchers) against that prefix alone. Usage: check_install.sh BUILD_DIR SOURCE_DIR
set -eu
build=$1 source=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" > "$work/install.log"
test -f "$work/prefix/include/rayproof/plugin.h"
# The installed headers are exactly the ones README lists as the public API (issue 41).
(cd "$work/prefix" && find include -name '*.h' | sort) > "$work/installed-headers"
grep -oE '^include/rayproof/[a-z_/]+\.h' "$source/README.md" | sort > "$work/readme-headers"
diff "$work/readme-headers" "$work/installed-headers" || { echo "README's public headers differ from those installed"; exit 1; }
test -x "$work/prefix/bin/rayproof"
# The bundled cases, scenes and examples come along, and the installed rayproof reads them.
test -f "$work/prefix/share/rayproof/cases/sphere.jsonl"
test -f "$work/prefix/share/rayproof/examples/plugins/weekend_sphere.c"
"$work/prefix/bin/rayproof" check "$work/prefix/share/rayproof/cases/sphere.jsonl" --variants stable > /dev/null 2>&1
"$work/prefix/bin/rayproof" render "$work/prefix/share/rayproof/scenes/seed1-sphere.json" -o "$work/seed1.png" > /dev/null 2>&1
# A plugin compiles against the installed header alone.
cc -O2 -shared -fPIC -I "$work/prefix/include" -o "$work/weekend.so" "$work/prefix/share/rayproof/examples/plugins/weekend_sphere.c" -lm
"$work/prefix/bin/rayproof" variants --plugin "$work/weekend.so" | grep -q '^weekend-sphere' 
cmake -S "$source/examples/consumer" -B "$work/consumer" -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_BUILD_TYPE=Release > "$work/configure.log"
cmake --build "$work/consumer" -j2 > "$work/build.log" || { cat "$work/build.log"; exit 1; }
"$work/consumer/my_sphere_test"
# The Python module, where it was built: importable from the prefix alone, and it judges.
if [ -n "${RAYPROOF_PYTHON:-}" ]; then
  (cd "$work" && PYTHONPATH="$work/prefix/$RAYPROOF_PYTHON_DIR" "$RAYPROOF_PYTHON" -c "
import rayproof
assert rayproof.__file__.startswith('$work/prefix/'), rayproof.__file__
assert rayproof.judge({'ray': {'origin': [0, 0, -5], 'direction': [0, 0, 1]},
                       'shape': {'type': 'sphere', 'center': [0, 0, 0], 'radius': 1}})['class'] == 'enter'
")
fi
