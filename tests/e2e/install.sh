#!/usr/bin/env bash
# install.sh SOURCE_DIR BUILD_DIR PYTHON
#
# make install's result (ctest label e2e), in an empty temporary prefix:
# cmake --install puts siproject and simetrics in PREFIX/bin (--version
# names the version and the git revision), the library, its headers and a
# CMake package under PREFIX, and the Python module in PREFIX's
# site-packages; the example program of docs/api.md (its CMakeLists.txt and
# consumer.cpp taken from the page's marked code blocks, so that the page
# cannot drift) finds the package, builds against it and runs (the ramp's
# middle is 0.5); the module imports
# from the prefix and projects; the installed siproject projects a file.
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: ${0##*/} SOURCE_DIR BUILD_DIR PYTHON" >&2; exit 64; }
src=$1 build=$2 python=$3
unset MAKEFLAGS MFLAGS MAKELEVEL GNUMAKEFLAGS
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sis-install.XXXXXX")
trap 'rm -rf -- "$tmp"' EXIT
prefix=$tmp/prefix
fail() { echo "FAIL: $*" >&2; exit 1; }

cmake --install "$build" --prefix "$prefix" > "$tmp/install.log" || { cat "$tmp/install.log" >&2; fail "cmake --install"; }
for f in bin/siproject bin/simetrics lib/libsis.a include/sis/engine.h include/sis/settings.h \
         lib/cmake/sis/sisConfig.cmake lib/cmake/sis/sisConfigVersion.cmake lib/cmake/sis/sisTargets.cmake; do
  [ -e "$prefix/$f" ] || fail "$f not installed"
done
version=$("$prefix/bin/siproject" --version)
[[ $version =~ ^siproject\ [0-9]+\.[0-9]+\ \(git\ .+\)$ ]] || fail "siproject --version printed '$version'"
[[ $("$prefix/bin/simetrics" --version) == simetrics* ]] || fail "simetrics --version"
echo "$version"

# docs/api.md's example, built outside the project against the installed package:
# each block after a "<!-- consumer: FILE -->" line is FILE
mkdir "$tmp/consumer-src"
awk -v dir="$tmp/consumer-src" '
  /^<!-- consumer: [^ ]+ -->$/ { file = dir "/" $3; next }
  file != "" && /^```/ { if (inside) { inside = 0; file = "" } else inside = 1; next }
  inside { print > file }
' "$src/docs/api.md"
for f in CMakeLists.txt consumer.cpp; do
  [ -s "$tmp/consumer-src/$f" ] || fail "docs/api.md has no consumer block for $f"
done
cmake -S "$tmp/consumer-src" -B "$tmp/consumer" -DCMAKE_PREFIX_PATH="$prefix" > "$tmp/consumer.log" 2>&1 &&
  cmake --build "$tmp/consumer" >> "$tmp/consumer.log" 2>&1 || { cat "$tmp/consumer.log" >&2; fail "the consumer does not build"; }
middle=$("$tmp/consumer/consumer")
[ "$middle" = "0.500000" ] || fail "the consumer printed $middle, not 0.500000"

# the Python module from the prefix
site=$(find "$prefix/lib" -maxdepth 3 -type d -name site-packages | head -1)
[ -n "$site" ] && [ -f "$site/siproject/__init__.py" ] || fail "no siproject package in PREFIX's site-packages"
PYTHONPATH=$site "$python" -c "
import numpy as np, siproject, sys
assert siproject.__file__.startswith(sys.argv[1]), siproject.__file__
a = siproject.project(np.full((32, 32, 3), 0.25, np.float32), factor=4)
assert a.shape == (8, 8, 3) and np.allclose(a, 0.25, atol=1e-6), a
" "$site" || fail "the installed module"

# the installed tool on a file
PYTHONPATH=$site "$python" -c "
import numpy as np, siproject, sys
siproject.write_image(sys.argv[1], np.full((32, 32, 3), 0.25, np.float32))" "$tmp/in.exr"
"$prefix/bin/siproject" "$tmp/in.exr" -o "$tmp/out.png" --factor 4 -q || fail "the installed siproject"
[ -s "$tmp/out.png" ] || fail "no output from the installed siproject"
echo "install: every part in place and working"
