# make install's Python package (tools/python/CMakeLists.txt): run at
# install time, when PREFIX (CMAKE_INSTALL_PREFIX) is known. The package
# goes where the interpreter looks under PREFIX: of its site directories
# (site.getsitepackages(), sysconfig's platlib and purelib) those under
# PREFIX, the one nearest it (/usr: lib/python3/dist-packages, not
# local/lib/...); with none, its posix_prefix scheme under PREFIX
# (lib/pythonX.Y/site-packages), and a note of how to use it. The
# interpreter: $SIS_INSTALL_PYTHON, else the build's.
set(python "$ENV{SIS_INSTALL_PYTHON}")
if(python STREQUAL "")
  set(python "${SIS_BUILD_PYTHON}")
endif()
set(prefix "${CMAKE_INSTALL_PREFIX}")
set(found 0)
if(NOT SIS_PYTHON_SITE STREQUAL "")
  set(site "${prefix}/${SIS_PYTHON_SITE}")
else()
  execute_process(
    COMMAND "${python}" -c [=[
import os, site, sys, sysconfig
prefix = os.path.realpath(sys.argv[1])
dirs = list(getattr(site, "getsitepackages", lambda: [])())
dirs += [sysconfig.get_paths()["platlib"], sysconfig.get_paths()["purelib"]]
under = []
for d in dirs:
    r = os.path.relpath(os.path.realpath(d), prefix)
    if not r.startswith(os.pardir) and r != ".":
        under.append((len(r.split(os.sep)), d))
version = "%d.%d" % sys.version_info[:2]
if under:
    print(1, version, min(under)[1], sep="\n")
else:
    scheme = sysconfig.get_path("platlib", "posix_prefix", {"base": prefix, "platbase": prefix})
    print(0, version, scheme, sep="\n")
]=] "${prefix}"
    OUTPUT_VARIABLE answer OUTPUT_STRIP_TRAILING_WHITESPACE RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "The Python module: ${python} could not be asked where it looks for packages "
                        "(set SIS_INSTALL_PYTHON to an interpreter, or SIS_PYTHON_SITE)")
  endif()
  string(REPLACE "\n" ";" answer "${answer}")
  list(GET answer 0 found)
  list(GET answer 1 version)
  list(GET answer 2 site)
endif()
file(INSTALL ${SIS_MODULE_FILES} DESTINATION "${site}/siproject")
if(found)
  message(STATUS "The Python module siproject: ${site}/siproject (${python} imports it)")
else()
  message(STATUS "The Python module siproject: ${site}/siproject; ${python} does not look there: "
                 "PYTHONPATH=${site} ${python} -c 'import siproject'")
endif()
if(DEFINED version AND NOT version STREQUAL SIS_MODULE_PYTHON_VERSION)
  message(WARNING "The Python module siproject is built for Python ${SIS_MODULE_PYTHON_VERSION} "
                  "(${SIS_BUILD_PYTHON}), ${python} is Python ${version}: it cannot import it")
endif()
