# hri_sync: one-command setup, test and demo on Debian 12 (bookworm).
SHELL := /bin/bash
ROOT := $(abspath .)
WS := $(ROOT)/.ws
VENV := $(ROOT)/.venv
ROS_PY := /usr/bin/python3
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
APT_PACKAGES := $(shell grep -v '^\#' $(ROOT)/scripts/apt-packages.txt)
PIP_PACKAGES := rosbags pylsl mcap
SOURCE := source $(WS)/devel/setup.bash

.PHONY: setup apt venv build test unit check test-install test-site rostest tracker-accuracy \
	test-load demo demo-sensors demo-fusion bench bench-sensors \
	bench-dj-rob clean

# The venv (pip) and the build (the compiler) at once, after apt.
setup: apt
	@$(MAKE) --no-print-directory -j2 venv build

apt:
	@missing=$$(dpkg-query -W -f='$${Package} $${Status}\n' $(APT_PACKAGES) 2>/dev/null \
	  | awk '$$4 == "installed" {print $$1}' | sort | comm -13 - <(tr ' ' '\n' <<< "$(APT_PACKAGES)" | sort)); \
	if [ -n "$$missing" ]; then \
	  echo "apt-get install:" $$missing; \
	  $(SUDO) apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends $$missing; \
	fi

venv: $(VENV)/.done

# .done holds the package list installed: a package added to PIP_PACKAGES
# is installed into an existing venv too.
$(VENV)/.done: FORCE
	@[ "$$(cat $@ 2>/dev/null)" = "$(PIP_PACKAGES)" ] || { \
	  $(ROS_PY) -m venv --system-site-packages $(VENV) && \
	  $(VENV)/bin/pip install -q $(PIP_PACKAGES) && \
	  echo "$(PIP_PACKAGES)" > $@; }

FORCE:

build:
	@mkdir -p $(WS)/src $(WS)/devel/lib/python3/dist-packages
	@# The workspace sees the package through links to its files, not a
	@# link to the folder that holds .ws (find, in rosrun, would loop).
	@[ ! -L $(WS)/src/hri_sync ] || rm $(WS)/src/hri_sync
	@mkdir -p $(WS)/src/hri_sync && cd $(ROOT) && for f in * .[!.]*; do \
	  case $$f in .ws|.venv|.git) ;; *) ln -sfn $(ROOT)/$$f $(WS)/src/hri_sync/$$f;; esac; \
	done; find $(WS)/src/hri_sync -maxdepth 1 -xtype l -delete
	@# A job per core, off setup's jobserver (where pip holds a slot) and
	@# without catkin_make's default load limit (-l: a load left by a
	@# previous run would hold the build to one job).
	@cd $(WS) && source /usr/share/catkin/setup.bash 2>/dev/null; \
	  env -u MAKEFLAGS -u MFLAGS catkin_make -j$$(nproc) -DPYTHON_EXECUTABLE=$(ROS_PY) -DCMAKE_BUILD_TYPE=Release \
	  -DCATKIN_ENABLE_TESTING=ON > $(WS)/build.log 2>&1 \
	  || { tail -40 $(WS)/build.log; exit 1; }
	@echo "built: source $(WS)/devel/setup.bash"

# Each stage's command (the targets below run setup first; `test` runs it
# once, then the stages).
UNIT = cd $(ROOT) && PYTHONPATH=$(ROOT)/src:$$PYTHONPATH $(VENV)/bin/python -m pytest -q test/unit
CHECK = $(ROOT)/scripts/check_package.sh
INSTALL_CHECK = $(ROOT)/test/system/install_space.sh
SITE = $(SOURCE) && $(ROS_PY) $(ROOT)/test/system/site_multihost.py
# The tracker's accuracy table against its baseline (bench/tracker_regression.py).
TRACKER_ACCURACY = $(SOURCE) && $(ROS_PY) $(ROOT)/bench/tracker_regression.py --check $(ROOT)/test/data/tracker_accuracy.json
ROSTESTS = $(SOURCE) && $(ROS_PY) $(ROOT)/scripts/run_rostests.py $(ROOT)/test
# What a newcomer meets: the traps found on a fresh clone, and the first
# hour of the README and the "add a sensor" guide (test/system/).
SYSTEM_PY = $(SOURCE) && PYTHONPATH=$(ROOT)/support:$$PYTHONPATH $(VENV)/bin/python
TRAPS = $(SYSTEM_PY) $(ROOT)/test/system/newcomer_traps.py
FIRST_HOUR = $(SYSTEM_PY) $(ROOT)/test/system/first_hour.py

# numpy, which every rospy message module imports, starts an OpenBLAS
# thread per core (0.13 s of CPU per process); none of the suite's ~1500
# Python processes needs them.
test unit check test-install test-site rostest: export OPENBLAS_NUM_THREADS = 1

unit: setup
	$(UNIT)

# rosdep keys, catkin_lint, roslaunch-check, mypy (scripts/check_package.sh).
check: setup
	@$(CHECK)

# make build's install, staged in a temporary folder, runs the nodes and tools (test/system/install_space.sh).
test-install: setup
	@$(INSTALL_CHECK)

# The site launch files on four network namespaces (root; test/system/site_multihost.py).
test-site: setup
	@$(SITE)

rostest: setup
	@$(ROSTESTS)

tracker-accuracy: setup
	@$(TRACKER_ACCURACY)

# One pool runs the rostests (each in a network namespace of its own) and
# the other stages, ROSTEST_JOBS (4) + 1 jobs at once, longest first (one
# more once the stages are done), up to ROSTEST_MAX_JOBS (3 JOBS) while a
# fifth of the CPU is idle; a failed stage's or test's log tail is printed
# (all logs: .ws/test_logs/).
test: setup
	@j=$${ROSTEST_JOBS:-4}; $(ROSTESTS) --jobs $$((j + 1)) \
	  --max-jobs $${ROSTEST_MAX_JOBS:-$$((3 * j))} \
	  --stage 'unit=$(UNIT)' --stage 'check=$(CHECK)' \
	  --stage 'install_space=$(INSTALL_CHECK)' --stage 'site_multihost=$(SITE)' \
	  --stage 'tracker_accuracy=$(TRACKER_ACCURACY)' \
	  --stage 'newcomer_traps=$(TRAPS)' --stage 'first_hour=$(FIRST_HOUR)'

# `make test` RUNS times in a row beside one busy loop per core, JSON
# summary last (scripts/test_under_load.py; e.g. make test-load RUNS=1).
RUNS ?= 3
test-load:
	@$(ROS_PY) $(ROOT)/scripts/test_under_load.py --runs $(RUNS)

demo: setup
	@$(SOURCE) && $(ROS_PY) $(ROOT)/scripts/demo.py

# One round of a skeleton, an IMU, an audio and a camera client, each on a
# skewed clock (scripts/demo_sensors.py; docs/sensors.md).
demo-sensors: setup
	@$(SOURCE) && $(ROS_PY) $(ROOT)/scripts/demo_sensors.py

# The data path at camera and IMU/audio bandwidth, 60 s windows (JSON;
# bench/sensor_bandwidth.py, docs/sensors.md).
bench-sensors: setup
	@$(SOURCE) && $(ROS_PY) $(ROOT)/bench/sensor_bandwidth.py --dur 60

bench: setup
	@$(SOURCE) && $(ROS_PY) $(ROOT)/bench/sync_skew.py --clients 2 --rounds 20

# Three virtual Kinects around one dancer, each tracked live inside a
# client on its own skewed clock, fused by the fusion node; each view's and
# the fused error and the latency (scripts/demo_fusion.py; docs/fusion.md).
demo-fusion: setup
	@$(SOURCE) && $(ROS_PY) $(ROOT)/scripts/demo_fusion.py

bench-dj-rob: setup
	@$(SOURCE) && $(ROS_PY) $(ROOT)/bench/dj_rob_start.py --rounds 10 --dur 3

clean:
	rm -rf $(WS) $(VENV)
