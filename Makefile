# Shift-invariant rendering: the project's make driver.
#   make        set up, build, render the default scene and form its images
#   make test   set up, build, run every test (ctest)
BUILD ?= build
JOBS  ?= $(shell nproc)

.PHONY: all setup build test clean
.DEFAULT_GOAL := all

setup:
	@bash scripts/setup.sh

build: setup
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS) >/dev/null
	@cmake --build $(BUILD) -j $(JOBS)

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

clean:
	rm -rf $(BUILD) out
