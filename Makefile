# Two commands do all the set-up on a fresh machine:
#   make run   - create .venv from the package index, install, run the node on the default scene
#   make test  - create .venv from the package index, install, run the whole test suite
# Everything is pinned; nothing needs to be installed by hand.

PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
SCENE  ?= mooring_line
ARGS   ?=

ROS_PKGS := ros-jazzy-rclpy==7.1.6 ros-jazzy-common-interfaces==5.3.6 \
            ros-jazzy-rmw-fastrtps-cpp==8.4.3
RUN_PKGS := numpy==2.4.6 scipy==1.17.1 pyyaml==6.0.3 mcap==1.6.0 mcap-ros2-support==0.6.0 \
            numba==0.68.1 matplotlib==3.11.2 \
            dask==2026.8.0 distributed==2026.8.0 pyarrow==26.0.1 tqdm==4.70.1 \
            foxglove-sdk==0.30.3
TEST_PKGS := pytest==9.2.0 pytest-timeout==2.4.0 pytest-xdist==3.8.0 execnet==2.1.2 sympy==1.14.0 rosbags==0.11.9 ruff==0.17.6 \
             rainflow==3.2.0 yourdfpy==0.0.60 websockets==17.4 protobuf==7.36.2 \
             moorpy==1.3.0

# The ROS wheels install their libraries and message definitions into the venv prefix.
export AMENT_PREFIX_PATH := $(abspath $(VENV))
export RMW_IMPLEMENTATION := rmw_fastrtps_cpp
export PYTHONUNBUFFERED := 1

DEPS_STAMP := $(VENV)/.deps-installed
PKG_STAMP  := $(VENV)/.pkg-installed
SOURCES    := setup.py setup.cfg package.xml $(shell find cable_sim config msg_configs launch -type f \( -name '*.py' -o -name '*.yaml' \))

.PHONY: run test lint bench figures realtime-bench clean venv

venv: $(PKG_STAMP)

$(DEPS_STAMP): Makefile
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q $(ROS_PKGS) $(RUN_PKGS) $(TEST_PKGS)
	touch $@

$(PKG_STAMP): $(DEPS_STAMP) $(SOURCES)
	rm -rf build  # setuptools would copy modules removed from the tree back into site-packages
	$(PY) -m pip install -q --no-deps --force-reinstall .
	touch $@

run: $(PKG_STAMP)
	$(VENV)/bin/cable_sim_node --ros-args --params-file config/$(SCENE).yaml $(ARGS)

# The suite in two parts: all but the wall-clock tests on TEST_WORKERS processes (one per core of
# the 2-core CI machine; --dist loadscope keeps a module's tests, and so its module-scoped node or
# bench fixture, on one worker), then the tests marked `realtime` alone. At most 4 workers (worker
# k of N draws its ROS domains from the d % N == k part of 10..100, test/ros_util.isolate_ros).
TEST_WORKERS ?= 2

test: $(PKG_STAMP)
	$(VENV)/bin/ruff check cable_sim test launch
	$(PY) -m pytest -q -n $(TEST_WORKERS) --dist loadscope -m "not realtime" test
	$(PY) -m pytest -q -m realtime test

lint: $(PKG_STAMP)
	$(VENV)/bin/ruff check cable_sim test launch

# Speed against error, issue 13's targets in one invocation (optional MuJoCo and MoorDyn peers:
# installs the bench extra; 24-62 min on 2-vCPU VMs, README "Speed against error"). ARGS adds
# to it, e.g. ARGS="--resume CSV".
BENCH_ARGS ?= --full --n 40 80 160 320 640 2000 --morison-n 40 80 160 320 640 --large-n-from 640 \
	--large-n-integrators rk4 rosenbrock2 ros34pw2 ros34pw2_adaptive w6s4os radau_iia \
	radau_iia_adaptive --mujoco-n 80 \
	--out results/bench --cache results/bench/cache
# The node's two targets first (real time wants a machine nothing else loads), then the studies,
# whose summary reads the two CSVs.
bench: $(PKG_STAMP)
	$(PY) -m pip install -q mujoco==4.0.0 moordyn==2.7.2
	$(PY) -m cable_sim.analysis.realtime_bench --seconds 60 --record --n-links 2000 --tag n2000
	$(PY) -m cable_sim.analysis.recorder_bench --repeats 8
	OPENBLAS_NUM_THREADS=1 $(VENV)/bin/cable_sim_bench $(BENCH_ARGS) $(ARGS)

# Node tick jitter in real time (results/realtime/).
realtime-bench: $(PKG_STAMP)
	$(PY) -m cable_sim.analysis.realtime_bench --seconds 30 --record

# README figures: the paper's anchored scene run by the node (fast clock), then the replay tool.
figures: $(PKG_STAMP)
	mkdir -p docs results/recording
	ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST $(VENV)/bin/cable_sim_node --ros-args \
	    --params-file config/paper_anchored_forced.yaml -p clock_mode:=fast -p duration:=15.5 \
	    -p exit_at_end:=true -p record_path:=results/recording/paper_anchored_forced.mcap
	$(VENV)/bin/cable_sim_replay results/recording/paper_anchored_forced.mcap \
	    --frames docs/frames_paper_anchored.png --tension docs/tension_paper_anchored.png \
	    --gif results/recording/paper_anchored_forced.gif --resim

clean:
	rm -rf $(VENV) build *.egg-info
