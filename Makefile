# servokit: `make demo` and `make test` work on a fresh Debian machine.
# Both install the Debian packages servokit needs (as root, with apt-get), or print the
# exact command to run and stop (as another user); then configure and build with CMake.

BUILD_DIR   ?= build
BUILD_TYPE  ?= Release
JOBS        ?= $(shell nproc 2>/dev/null || echo 2)
SERVOKIT    := $(BUILD_DIR)/reports/servokit
# Warnings as errors only when asked (CI exports SERVOKIT_WERROR=ON); otherwise the cached
# choice stays, so that `make demo` after `make test` does not rebuild everything.
CMAKE_FLAGS := -DCMAKE_BUILD_TYPE=$(BUILD_TYPE)
ifdef SERVOKIT_WERROR
CMAKE_FLAGS += -DSERVOKIT_WERROR=$(SERVOKIT_WERROR)
endif
MAKEFLAGS   += --no-print-directory

# Build and run dependencies (DESIGN.md, "Dependencies").
PACKAGES := cmake g++ make pkg-config libeigen3-dev libsundials-dev libarpack2-dev libgsl-dev \
            catch2 libginac-dev libyaml-cpp-dev nlohmann-json3-dev libcli11-dev gnuplot-nox \
            libopenmpi-dev openmpi-bin
# Only the benchmarks need the SciPy peer.
BENCH_PACKAGES := python3-scipy python3-numpy python3-yaml

.PHONY: all deps bench-deps configure build test demo bench clean

all: build

deps:
	@./scripts/install-deps.sh $(PACKAGES)

bench-deps:
	@./scripts/install-deps.sh $(PACKAGES) $(BENCH_PACKAGES)

configure: deps
	@cmake -S . -B $(BUILD_DIR) $(CMAKE_FLAGS) >/dev/null

build: configure
	@cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	@cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

demo: build
	@./scripts/demo.sh $(SERVOKIT)

bench: bench-deps configure
	@cmake --build $(BUILD_DIR) -j $(JOBS)
	@./bench/run.sh $(BUILD_DIR)

clean:
	rm -rf $(BUILD_DIR)
