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
test -x "$work/prefix/bin/rayproof"
cmake -S "$source/examples/consumer" -B "$work/consumer" -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_BUILD_TYPE=Release > "$work/configure.log"
cmake --build "$work/consumer" -j2 > "$work/build.log" || { cat "$work/build.log"; exit 1; }
"$work/consumer/my_sphere_test"
