#!/usr/bin/env bash
# install.sh SOURCE_DIR BUILD_DIR PYTHON
#
# make install's result (ctest label e2e), in an empty temporary prefix:
# cmake --install puts siproject and simetrics in PREFIX/bin (--version
# names the version and the git revision), the library, its headers and a
# CMake package under PREFIX, and the Python module where the interpreter
# looks under PREFIX (or, where it does not, PREFIX's site-packages and a
# note of how to use it); the example program of docs/api.md (its
# CMakeLists.txt and consumer.cpp taken from the page's marked code blocks,
# so that the page cannot drift) finds the package, builds against it and
# runs (the ramp's middle is 0.5); the module imports
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

# the Python module from the prefix, where the build's interpreter (a venv)
# does not look: PREFIX/lib/pythonX.Y/site-packages, and said so
site=$(find "$prefix/lib" -maxdepth 3 -type d -name site-packages | head -1)
[ -n "$site" ] && [ -f "$site/siproject/__init__.py" ] || fail "no siproject package in PREFIX's site-packages"
grep -qF "The Python module siproject: $site/siproject; $python does not look there: PYTHONPATH=$site" \
  "$tmp/install.log" || { cat "$tmp/install.log" >&2; fail "no note of where the module went"; }
# where the interpreter looks under PREFIX: a venv's site-packages, and
# Debian's python3 under /usr/local (lib/python3.X/dist-packages: staged in
# DESTDIR)
"$python" -m venv --without-pip "$tmp/venv"
SIS_INSTALL_PYTHON=$tmp/venv/bin/python cmake --install "$build" --prefix "$tmp/venv" --component python \
  > "$tmp/venv.log" || fail "cmake --install into a venv"
venv_site=$("$tmp/venv/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["platlib"])')
[ -f "$venv_site/siproject/__init__.py" ] && ls "$venv_site"/siproject/_core*.so > /dev/null ||
  fail "the module is not in the venv's $venv_site"
grep -qF "$venv_site/siproject ($tmp/venv/bin/python imports it)" "$tmp/venv.log" || fail "$(cat "$tmp/venv.log")"
if [ -x /usr/bin/python3 ] && /usr/bin/python3 -c 'import sys, site; sys.exit("/usr/local/lib/python%d.%d/dist-packages" % sys.version_info[:2] not in site.getsitepackages())'; then
  deb_site=$(/usr/bin/python3 -c 'import sys; print("/usr/local/lib/python%d.%d/dist-packages" % sys.version_info[:2])')
  DESTDIR=$tmp/root SIS_INSTALL_PYTHON=/usr/bin/python3 cmake --install "$build" --prefix /usr/local \
    --component python > "$tmp/deb.log" || fail "cmake --install for /usr/bin/python3"
  [ -f "$tmp/root$deb_site/siproject/__init__.py" ] || fail "not in $deb_site: $(cat "$tmp/deb.log")"
  grep -qF "$deb_site/siproject (/usr/bin/python3 imports it)" "$tmp/deb.log" || fail "$(cat "$tmp/deb.log")"
fi
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
