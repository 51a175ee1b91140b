# Two commands set up a fresh Debian 12 machine and do the work:
#   make demo   installs what is missing, builds, runs the main job on the default scene
#   make test   installs what is missing, builds, runs the C++ and Python test suites
# Each step leaves a stamp in .make/ and is skipped while its inputs are unchanged.

SHELL := /bin/bash
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(PY) -m pip --disable-pip-version-check -q
STAMPS := .make
JOBS ?= $(shell nproc)
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

APT_PACKAGES := mesa-vulkan-drivers libvulkan-dev vulkan-validationlayers glslc libshaderc-dev glslang-dev \
	spirv-tools spirv-headers cmake ninja-build g++ libgtest-dev python3-venv python3-dev python3-pykdl
# build requirements of the engine itself (pyproject's build-system), installed once into the venv
BUILD_REQUIREMENTS := "scikit-build-core>=0.10" "pybind11>=2.12" "numpy>=1.26" ninja
ENGINE_SOURCES := $(shell find engine shaders cmake -type f 2>/dev/null) CMakeLists.txt pyproject.toml

.PHONY: all demo test test-cpp test-python deps build clean FORCE
all: build

$(STAMPS):
	@mkdir -p $@

# the apt package list, rewritten only when it changes (so a package added here gets installed)
$(STAMPS)/apt-packages: FORCE | $(STAMPS)
	@echo '$(APT_PACKAGES)' | cmp -s - $@ || echo '$(APT_PACKAGES)' > $@

# apt: only the packages that are missing
$(STAMPS)/apt: $(STAMPS)/apt-packages | $(STAMPS)
	@missing=$$(for p in $(APT_PACKAGES); do dpkg -s $$p >/dev/null 2>&1 || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "apt: installing $$missing"; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq $$missing; \
	fi
	@touch $@

# Python 3.11 virtualenv (Debian 12's python3 is 3.11; a python3.11 on PATH is used first)
$(VENV)/bin/python: | $(STAMPS)/apt
	@py=$$(command -v python3.11 || command -v python3); \
	$$py -c 'import sys; assert sys.version_info[:2] >= (3, 11), sys.version' && $$py -m venv $(VENV)

$(STAMPS)/venv: $(VENV)/bin/python | $(STAMPS)
	$(PIP) install --upgrade pip
	$(PIP) install $(BUILD_REQUIREMENTS)
	@touch $@

# PyKDL for the dVRK's own Python clients (tests/twin/test_dvrk_scripts.py): Debian's python3-pykdl
# builds it for the system Python 3.11; link just its extension module(s) into the venv's
# site-packages (the whole of /usr/lib/python3/dist-packages on the path would shadow numpy etc.)
$(STAMPS)/pykdl: $(STAMPS)/venv $(STAMPS)/apt
	@site=$$($(PY) -c 'import sysconfig; print(sysconfig.get_paths()["platlib"])'); \
	files=$$(dpkg -L python3-pykdl | grep -E '^/usr/lib/python3/dist-packages/PyKDL[^/]*$$'); \
	[ -n "$$files" ] || { echo "python3-pykdl installs no PyKDL module"; exit 1; }; \
	for f in $$files; do ln -sfn "$$f" "$$site/"; done
	$(PY) -c 'import PyKDL; PyKDL.Frame()'
	@touch $@

# the engine and the package, editable; rebuilt when engine, shader or build sources change
$(STAMPS)/build: $(STAMPS)/venv $(ENGINE_SOURCES)
	$(PIP) install --no-build-isolation -e ".[test]"
	@touch $@

# ROS 2 Jazzy wheels (pinned) into the same venv, and the ros_ws packages (crtk_msgs, cressim_ros)
ROS_SOURCES := $(shell find ros_ws/src -type f 2>/dev/null) ros_ws/build.sh
$(STAMPS)/ros: $(STAMPS)/build $(ROS_SOURCES)
	bash ros_ws/build.sh $(VENV)
	@touch $@

deps: $(STAMPS)/build $(STAMPS)/ros $(STAMPS)/pykdl
build: $(STAMPS)/build $(STAMPS)/ros $(STAMPS)/pykdl

# C++ unit tests (GoogleTest) in their own build tree
build/cpp/build.ninja: $(STAMPS)/apt CMakeLists.txt engine/CMakeLists.txt
	cmake -S . -B build/cpp -G Ninja -DCRESSIM_PYTHON=OFF -DCRESSIM_TESTS=ON -DCMAKE_BUILD_TYPE=Release

test-cpp: build/cpp/build.ninja
	cmake --build build/cpp -j $(JOBS)
	cd build/cpp && ctest --output-on-failure

# ros_ws/env.sh puts rclpy, the built messages and the twin on the paths. Two pytest runs at once:
# the twin's tests mostly wait (on DDS, on the twin's real-time tick, on the dVRK's scripts), the
# rest mostly compute, so together they take about the longer one's time. Each run takes ROS
# domain ids of its own (CRESSIM_TEST_DOMAINS, tests/ros/conftest.py); the twin's log follows.
test-python: $(STAMPS)/build $(STAMPS)/ros $(STAMPS)/pykdl
	@echo "pytest: start $$(date -u +%FT%TZ)"
	@source ros_ws/env.sh || exit 1; export CRESSIM_VALIDATION=1; \
	{ CRESSIM_TEST_DOMAINS=1-60 $(PY) -m pytest -p no:cacheprovider tests/twin > $(STAMPS)/pytest-twin.log 2>&1; \
	  echo $$? > $(STAMPS)/pytest-twin.rc; } & \
	CRESSIM_TEST_DOMAINS=61-100 $(PY) -m pytest tests --ignore=tests/twin; rest=$$?; \
	wait; echo "----- tests/twin (run beside the rest):"; cat $(STAMPS)/pytest-twin.log; \
	twin=$$(cat $(STAMPS)/pytest-twin.rc); echo "pytest: done $$(date -u +%FT%TZ)"; \
	[ $$rest = 0 ] && [ $$twin = 0 ]

test: test-cpp test-python

demo: $(STAMPS)/build $(STAMPS)/ros
	$(VENV)/bin/cressim info
	$(VENV)/bin/cressim demo batched
	source ros_ws/env.sh && $(PY) -m cressim_ros.demo

clean:
	rm -rf build $(STAMPS) out
