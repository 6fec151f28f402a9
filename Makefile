# Two commands: `make demo` and `make test` (see README.md). Both install what is missing first.
SHELL := /bin/bash
ROOT := $(CURDIR)
VENV := $(ROOT)/.venv
# The ROS interpreter's venv comes first, so no other python3 on PATH is ever used.
export PATH := $(VENV)/bin:/usr/bin:/bin:$(PATH)

.PHONY: setup build demo test lint load-check docker-base docker-test clean

setup:
	@tools/setup.sh

build: setup

demo: setup
	@tools/ws_run.sh tools/run_demo.py

test: setup
	@tools/run_tests.sh

lint: setup
	@HARVEST_ONLY_LINT=1 tools/run_tests.sh

# every mission scenario beside two CPU hogs (stress-ng); one line per scenario
load-check: setup
	@tools/ws_run.sh tools/load_check.py

docker-base:
	@docker/make_base.sh

docker-test: docker-base
	@docker/build_and_test.sh

clean:
	rm -rf build devel install test_results build.log
