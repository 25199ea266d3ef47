#!/usr/bin/env bash
# pip_install.sh SOURCE_DIR PYTHON
#
# `pip install .` of the project (pyproject.toml: scikit-build-core runs
# the project's CMake, the library and the module only) into an empty venv,
# the build's dependencies fetched from PyPI by pip (build isolation), numpy
# as the package's dependency (ctest label e2e: needs PyPI). Then: the
# dist-info names the version siproject.__version__ gives and lists the
# package's files only; the module imports from the venv and projects a
# flat image to its value; pip uninstall removes every file it installed.
set -euo pipefail
[ $# -eq 2 ] || { echo "usage: ${0##*/} SOURCE_DIR PYTHON" >&2; exit 64; }
src=$1 python=$2
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sis-pip.XXXXXX")
trap 'rm -rf -- "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

"$python" -m venv "$tmp/venv" || fail "python -m venv"
venv=$tmp/venv/bin/python
# the compiler cache where there is one: a second run rebuilds nothing
if command -v ccache > /dev/null; then export CMAKE_ARGS="-DCMAKE_CXX_COMPILER_LAUNCHER=ccache"; fi
# only the venv's own packages: no user site, nothing of the caller's path
env -u PYTHONPATH PYTHONNOUSERSITE=1 "$venv" -m pip install --disable-pip-version-check \
  --no-input "$src" > "$tmp/pip.log" 2>&1 || { tail -40 "$tmp/pip.log" >&2; fail "pip install $src"; }
env -u PYTHONPATH PYTHONNOUSERSITE=1 "$venv" - "$tmp/venv" <<'PY' || fail "the installed module"
import importlib.metadata as md, os, sys
import numpy as np
import siproject
venv = os.path.realpath(sys.argv[1])
assert os.path.realpath(siproject.__file__).startswith(venv), siproject.__file__
dist = md.distribution("siproject")
assert dist.version == siproject.__version__, (dist.version, siproject.__version__)
assert dist.metadata["Requires-Python"], "no Requires-Python"
files = sorted(str(f) for f in dist.files)
package = [f for f in files if not f.startswith("siproject-")]
assert "siproject/__init__.py" in package, files
assert any(f.startswith("siproject/_core.") and f.endswith(".so") for f in package), files
assert all(f.startswith("siproject/") for f in package), files  # no headers, library or tools
a = siproject.project(np.full((64, 48, 3), 0.25, np.float32), factor=4)
assert a.shape == (16, 12, 3) and np.allclose(a, 0.25, rtol=0, atol=1e-6), a
print("pip install: siproject", siproject.__version__, "for Python", dist.metadata["Requires-Python"],
      "with", len(files), "files")
PY
site=$("$venv" -c 'import sysconfig; print(sysconfig.get_paths()["platlib"])')
"$venv" -m pip uninstall --disable-pip-version-check -y siproject > "$tmp/uninstall.log" 2>&1 ||
  fail "pip uninstall: $(cat "$tmp/uninstall.log")"
[ ! -e "$site/siproject" ] || fail "pip uninstall left $(find "$site/siproject")"
echo "pip install: installed, imported, projected and uninstalled"
