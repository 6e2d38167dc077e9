# servokit: `make demo` and `make test` work on a fresh Debian machine.
# Both install the Debian packages servokit needs (as root, with apt-get), or print the
# exact command to run and stop (as another user); then configure and build with CMake.

BUILD_DIR   ?= build
BUILD_TYPE  ?= Release
JOBS        ?= $(shell nproc 2>/dev/null || echo 2)
SERVOKIT    := $(BUILD_DIR)/application/servokit
# Warnings as errors only when asked (CI exports SERVOKIT_WERROR=ON); otherwise the cached
# choice stays, so that `make demo` after `make test` does not rebuild everything.
CMAKE_FLAGS := -DCMAKE_BUILD_TYPE=$(BUILD_TYPE)
ifdef SERVOKIT_WERROR
CMAKE_FLAGS += -DSERVOKIT_WERROR=$(SERVOKIT_WERROR)
endif
MAKEFLAGS   += --no-print-directory

# Build and run dependencies (docs/development.md, "Building"). The Python module
# (application/python) needs pybind11 and the interpreter's headers, its tests pytest and numpy;
# its tables are pandas DataFrames (numpy structured arrays where pandas is missing, which CI
# must test too).
# `sweep --format hdf5|mat` needs HDF5 and matio; its tests read the files back with h5py and
# scipy.io.loadmat.
PACKAGES := cmake g++ make pkg-config libeigen3-dev libsundials-dev libarpack2-dev libgsl-dev \
            catch2 libginac-dev libyaml-cpp-dev nlohmann-json3-dev libcli11-dev gnuplot-nox \
            libopenmpi-dev openmpi-bin pybind11-dev python3-dev python3-pytest python3-numpy \
            python3-pandas libhdf5-dev libmatio-dev python3-h5py python3-scipy
# Only the benchmarks need the SciPy peers (bench/scipy_generic_sweep.py compiles model files
# with SymPy).
BENCH_PACKAGES := python3-scipy python3-numpy python3-yaml python3-sympy
# Only fuzzing needs clang and its libFuzzer runtime.
FUZZ_PACKAGES := clang libclang-rt-dev
# The formatter, pinned to Debian's clang-format 14 (.clang-format, docs/development.md "Style"): another
# version formats some constructs differently, and CI must judge every file alike.
FORMAT_PACKAGES := clang-format-14
CLANG_FORMAT    := clang-format-14

# Hardening (docs/hardening.md): the whole suite under AddressSanitizer and
# UndefinedBehaviorSanitizer, and the libFuzzer targets of tests/fuzz/.
SANITIZE_DIR  ?= build-sanitize
FUZZ_DIR      ?= build-fuzz
FUZZ_SECONDS  ?= 1800
FUZZ_TARGETS  := model_file expression matrix_market trajectory_file waypoint_file output_path
# The sanitizer and fuzzer builds compile as OSS-Fuzz does: -O1 with line tables only (-g1),
# enough for symbolized reports. -O2 -g took 1.7 times as long to compile under the
# instrumentation (analysis/zero_dynamics.cpp: 183 s against 107 s), and CI must stay short.
HARDENING_FLAGS := -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG"
# intercept_tls_get_addr=0: up to GCC 13 and LLVM 16 the sanitizers' __tls_get_addr
# interceptor can take a dynamic TLS block that starts at a certain page offset for a
# pre-2.25 glibc header and record a bogus range (google/sanitizers#1322); LeakSanitizer's
# tracer then dies scanning it at exit ("Tracer caught signal 11"). Only modules loaded by
# dlopen have dynamic TLS: here Open MPI's plugins, whose allocations tests/lsan.supp
# suppresses anyway. It hit every run of the 4-rank case of application.sweep_mpi on Debian 12
# (GCC 12.2, glibc 2.36, Open MPI 4.1.4).
SANITIZER_ENV := ASAN_OPTIONS=detect_stack_use_after_return=1:intercept_tls_get_addr=0 \
                 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
                 LSAN_OPTIONS=suppressions=$(CURDIR)/tests/lsan.supp:print_suppressions=0
# Issue #29: the API from 8 threads at once, in C++ (tests/servokit/threads_test.cpp) and in
# Python (tests/python/test_threads.py), under ThreadSanitizer. Only the libraries, that test
# and the Python module are built, with the hardening flags; GiNaC, SUNDIALS, the other
# libraries and the interpreter are not instrumented, so a race inside one shows as a race on
# the objects our code hands it. python.threads runs Debian's python3 with the TSan runtime
# preloaded (tests/python/CMakeLists.txt). Every report fails the run; tests/tsan.supp holds
# the one false report, glibc's, that the module's thread-local objects meet.
THREAD_DIR  ?= build-tsan
THREAD_SUPP := $(CURDIR)/tests/tsan.supp
THREAD_ENV  := TSAN_OPTIONS=halt_on_error=1:second_deadlock_stack=1:suppressions=$(THREAD_SUPP)

.PHONY: all deps bench-deps configure build test demo bench clean test-sanitize test-thread \
        fuzz-build fuzz-smoke fuzz format format-check

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

test-sanitize: deps
	@cmake -S . -B $(SANITIZE_DIR) $(HARDENING_FLAGS) -DSERVOKIT_SANITIZE=ON \
	  -DSERVOKIT_BUILD_BENCH=OFF $(filter -DSERVOKIT_WERROR=%,$(CMAKE_FLAGS)) >/dev/null
	@cmake --build $(SANITIZE_DIR) -j $(JOBS)
	@cd $(SANITIZE_DIR) && $(SANITIZER_ENV) ctest --output-on-failure -j $(JOBS)

test-thread: deps
	@cmake -S . -B $(THREAD_DIR) $(HARDENING_FLAGS) -DCMAKE_CXX_FLAGS=-fsanitize=thread \
	  -DSERVOKIT_BUILD_BENCH=OFF $(filter -DSERVOKIT_WERROR=%,$(CMAKE_FLAGS)) >/dev/null
	@cmake --build $(THREAD_DIR) -j $(JOBS) --target test_servokit_threads servokit_python
	@cd $(THREAD_DIR) && $(THREAD_ENV) ctest --output-on-failure -R '^(servokit|python)\.threads$$'

fuzz-build: deps
	@./scripts/install-deps.sh $(FUZZ_PACKAGES)
	@cmake -S . -B $(FUZZ_DIR) -DCMAKE_CXX_COMPILER=clang++ $(HARDENING_FLAGS) \
	  -DSERVOKIT_FUZZ=ON $(filter -DSERVOKIT_WERROR=%,$(CMAKE_FLAGS)) >/dev/null
	@cmake --build $(FUZZ_DIR) -j $(JOBS)

# CI's short run: 30 s per target from the seed corpus; any finding fails.
fuzz-smoke: fuzz-build
	@./scripts/fuzz.sh $(FUZZ_DIR) 30 $(FUZZ_TARGETS)

# The long run (FUZZ_SECONDS per target, 30 min by default), going on after findings; the
# corpus it grows stays in $(FUZZ_DIR)/corpus, findings in $(FUZZ_DIR)/findings.
fuzz: fuzz-build
	@FUZZ_KEEP_GOING=1 ./scripts/fuzz.sh $(FUZZ_DIR) $(FUZZ_SECONDS) $(FUZZ_TARGETS)

# Every C++ source and header of the repository, as git knows them.
FORMAT_FILES = $(shell git ls-files '*.cpp' '*.h')

# CI's check: fails, showing each place, when any file differs from clang-format's output.
format-check:
	@./scripts/install-deps.sh $(FORMAT_PACKAGES)
	@$(CLANG_FORMAT) --dry-run --Werror $(FORMAT_FILES)
	@echo "format-check: $(words $(FORMAT_FILES)) files are clang-format clean"

format:
	@./scripts/install-deps.sh $(FORMAT_PACKAGES)
	@$(CLANG_FORMAT) -i $(FORMAT_FILES)

clean:
	rm -rf $(BUILD_DIR) $(SANITIZE_DIR) $(THREAD_DIR) $(FUZZ_DIR)
