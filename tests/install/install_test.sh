#!/usr/bin/env bash
# Installs hysid into a prefix inside the build directory, checks that no installed file refers to the
# build directory, then configures, builds and runs examples/own-model against that prefix alone.
#   install_test.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
source=$(cd "$2" && pwd)
prefix=$build/install-test/prefix
work=$build/install-test/own-model
rm -rf "$build/install-test"
mkdir -p "$build/install-test"

cmake --install "$build" --prefix "$prefix" > "$build/install-test/install.log"
for f in bin/hysid lib/cmake/hysid/hysidConfig.cmake lib/cmake/hysid/hysidTargets.cmake \
         include/hysid/core/model/model.hpp include/hysid/experiments/cli/entry.hpp \
         share/hysid/models/wall-msd.toml share/doc/hysid/LICENSE; do
  [ -e "$prefix/$f" ] || { echo "FAIL: $prefix/$f not installed"; exit 1; }
done
# Only public headers: each one's own includes installed too, none reaching a PRIVATE dependency
# (Ceres, CGAL, toml++, muParser, SUNDIALS, CLI11), and the internal ones absent.
inc=$prefix/include/hysid
for h in sim/refine/solve.hpp core/sets/hull_nd.hpp core/io/toml_reader.hpp experiments/cli/cli.hpp; do
  [ ! -e "$inc/$h" ] || { echo "FAIL: the internal header $h is installed"; exit 1; }
done
while IFS= read -r h; do
  for dep in $(sed -n 's/^#include "\([^"]*\)".*/\1/p' "$h"); do
    [ -e "$inc/$dep" ] || { echo "FAIL: ${h#$inc/} includes $dep, which is not installed"; exit 1; }
  done
  if grep -En '^#include <((ceres|CGAL|toml\+\+|cvodes|nvector|sundials|CLI)/|muParser)' "$h"; then
    echo "FAIL: ${h#$inc/} includes a header of a PRIVATE dependency"; exit 1
  fi
done < <(find "$inc" -name '*.hpp')
# A sanitized build's binaries are left out: the instrumentation records each source's path as compiled
# (GCC 12's -ffile-prefix-map does not reach it), and generated sources lie in the build directory.
cache() { sed -n "s/^$1:[A-Z]*=//p" "$build/CMakeCache.txt"; }
scope=("$prefix")
if [[ "$(cache CMAKE_CXX_FLAGS)" == *-fsanitize* ]]; then
  scope=("$prefix/include" "$prefix/lib/cmake" "$prefix/share")
fi
if grep -rl --binary-files=text -F "$build" "${scope[@]}"; then
  echo "FAIL: the installed files above refer to the build directory $build"; exit 1
fi

# The installed CLI on an installed model file.
"$prefix/bin/hysid" models --show "$prefix/share/hysid/models/wall-msd.toml" | grep -q "guard wall: h(xi) = x - 1 (rising)"

# The example project, found through CMAKE_PREFIX_PATH only, with hysid's compiler and flags (a
# sanitizer build's libraries need the sanitizer's runtime at link time).
cmake -S "$source/examples/own-model" -B "$work" -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_CXX_COMPILER="$(cache CMAKE_CXX_COMPILER)" -DCMAKE_CXX_FLAGS="$(cache CMAKE_CXX_FLAGS)" \
      -DCMAKE_PREFIX_PATH="$prefix" > "$build/install-test/configure.log"
cmake --build "$work" > "$build/install-test/build.log" || { tail -20 "$build/install-test/build.log"; exit 1; }
"$work/my-hysid" models --show wall-msd-cpp | grep -q "wall-msd-cpp: mass on a spring hitting a wall at x = 1 (C++)"
"$work/my-hysid" simulate --model wall-msd-cpp --sigma 1e-4 --seed 2 --out "$work/wall.csv" > /dev/null
out=$("$work/my-hysid" identify --model wall-msd-cpp --data "$work/wall.csv")
echo "$out"
echo "$out" | grep -Eq "alpha k +=  ?(3\.99|4\.00)"
echo "$out" | grep -q "jumps detected: 3 (flow estimator ok, jump estimator ok)"
# The same data through the installed model file: the same estimates (same stdout but the name, and
# the truth's source: the sidecar names the model wall-msd-cpp, so the file's model wall-msd takes
# its own values, which are the same).
file_out=$("$prefix/bin/hysid" identify --model-file "$prefix/share/hysid/models/wall-msd.toml" --data "$work/wall.csv")
echo "$out" | grep -q "against the parameters in $work/wall.json"
same() { sed 1d | sed 's/wall-msd-cpp/wall-msd/; s/ against .*//'; }
if [ "$(echo "$out" | same)" != "$(echo "$file_out" | same)" ]; then
  echo "FAIL: the C++ model and the model file give different output:"; echo "$file_out"; exit 1
fi
"$work/my-hysid" identify --model no-such-model --data "$work/wall.csv" 2> "$work/err.txt" && exit 1
grep -q "wall-msd-cpp" "$work/err.txt"
echo "install test passed"
