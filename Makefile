# tracemesh — the four entry points of DEVELOPERS.md. Everything else is CMake.
BUILD_DIR        ?= build
SANITIZE_DIR     ?= build-asan
TSAN_DIR         ?= build-tsan
JOBS             ?= $(shell nproc)
LISTEN           ?= 127.0.0.1:8080
CACHE_DIR        ?= $(CURDIR)/cache
CMAKE_FLAGS      ?=
# The larger molecules the benchmarks read (1k4r_capsid, 2buk_capsid, ...): docs/benchmarks.md says how that set is
# made. The suite reads only tests/data/molecules/.
TRACEMESH_MOLECULES_DIR ?= $(if $(wildcard $(CURDIR)/../shared/molecules),$(abspath $(CURDIR)/../shared/molecules),$(CURDIR)/tests/data/molecules)
export TRACEMESH_MOLECULES_DIR

.PHONY: deps deps-run build-run install package test-package deps build test test-sanitize test-tsan run bench bench-paper bench-load bench-soak bench-chaos bench-replicas bench-sharp bench-nanoshaper bench-stages fuzz fuzz-campaign image test-image clean

# What building and running tracemesh and tracemeshd needs (`make run`), and what the suite adds (`make test`).
deps-run:
	@bash scripts/install-deps.sh --build-only

deps:
	@bash scripts/install-deps.sh

# The two programs only, without the suite's libraries and tools.
build-run: deps-run
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release -DTRACEMESH_BUILD_TESTS=OFF -DTRACEMESH_BUILD_BENCH=OFF $(CMAKE_FLAGS)
	cmake --build $(BUILD_DIR) -j $(JOBS) --target tracemesh tracemeshd

build: deps
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release -DTRACEMESH_BUILD_TESTS=ON -DTRACEMESH_BUILD_BENCH=ON $(CMAKE_FLAGS)
	cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) --timeout 900

# The AddressSanitizer + UndefinedBehaviorSanitizer configuration (CI runs it after `make test`).
test-sanitize: deps
	cmake -S . -B $(SANITIZE_DIR) -DCMAKE_BUILD_TYPE=CI -DTRACEMESH_SANITIZE="address;undefined" -DTRACEMESH_BUILD_BENCH=OFF $(CMAKE_FLAGS)
	cmake --build $(SANITIZE_DIR) -j $(JOBS)
	cd $(SANITIZE_DIR) && TRACEMESH_SANITIZED=1 ctest --output-on-failure -j $(JOBS) --timeout 1800

# ThreadSanitizer on the server: tracemeshd and the server and integration test executables only, with clang-14
# like the fuzz build (gcc 12's -Wtsan on atomic_thread_fence would be an error under -Werror). Reports go to
# $(TSAN_DIR)/tsan-report.<pid> (the integration tests' tracemeshd children too) and fail the target.
# tests/tsan.supp lists third-party false positives only, each with its reason. .ci/run runs it last.
TSAN_OPTIONS_ALL = halt_on_error=1 second_deadlock_stack=1 history_size=4 suppressions=$(CURDIR)/tests/tsan.supp log_path=$(CURDIR)/$(TSAN_DIR)/tsan-report
test-tsan: deps
	CXX=clang++-14 cmake -S . -B $(TSAN_DIR) -DCMAKE_BUILD_TYPE=CI -DTRACEMESH_SANITIZE=thread -DTRACEMESH_BUILD_BENCH=OFF $(CMAKE_FLAGS)
	cmake --build $(TSAN_DIR) -j $(JOBS) --target tracemeshd server_tests integration_tests
	rm -f $(TSAN_DIR)/tsan-report.*
	cd $(TSAN_DIR) && TRACEMESH_SANITIZED=1 TSAN_OPTIONS="$(TSAN_OPTIONS_ALL)" \
	  ctest -R '^(server|integration)\.' --output-on-failure -j $(JOBS) --timeout 1800
	@if ls $(TSAN_DIR)/tsan-report.* > /dev/null 2>&1; then cat $(TSAN_DIR)/tsan-report.*; \
	  echo "test-tsan: ThreadSanitizer reports above ($(TSAN_DIR)/tsan-report.*)" >&2; exit 1; fi

run: build-run
	mkdir -p $(CACHE_DIR)
	exec $(BUILD_DIR)/bin/tracemeshd --listen $(LISTEN) --cache-dir $(CACHE_DIR)

# Installs the programs, man pages, docs and the systemd unit under PREFIX (default /usr/local), as `cmake --install`.
PREFIX           ?= /usr/local
install: build-run
	@# The Python package too when this tree can build it (make build installed its packages): install.cmake
	@# installs it only if it was built.
	if cmake --build $(BUILD_DIR) --target help | grep -qw tracemesh_python; then \
	  cmake --build $(BUILD_DIR) -j $(JOBS) --target tracemesh_python; fi
	cmake --install $(BUILD_DIR) --prefix $(PREFIX)

# The Debian package (CPack) in $(BUILD_DIR): tracemesh_<version>_<arch>.deb.
package: build-run
	cd $(BUILD_DIR) && cpack -G DEB

# The package installed into a clean Debian 12 root (debootstrap) and used there (tests/package/install_test.sh).
test-package: package
	bash tests/package/install_test.sh $(BUILD_DIR)

# The molecule ladder, lattice vs trace (bench/run_ladder.sh: RUNS, MAX_ATOMS, MOLECULES, THREADS...).
bench: build
	BUILD_DIR=$(BUILD_DIR) bash bench/run_ladder.sh

# Load: 1,000 mixed requests at 64 concurrent against tracemeshd; Markdown p50/p99 table, fails on any 5xx
# (bench/load_bench.py: LOAD_ARGS="--requests 200 --seed 3" ...).
bench-load: build
	python3 bench/load_bench.py --daemon $(BUILD_DIR)/bin/tracemeshd --molecules $(TRACEMESH_MOLECULES_DIR) $(LOAD_ARGS)

# Soak: the load benchmark's mix for 30 min against one tracemeshd, its RSS, fds and threads sampled every 10 s
# (bench/soak_bench.py: SOAK_ARGS="--duration 600" ...). Not in CI.
bench-soak: build
	python3 bench/soak_bench.py --daemon $(BUILD_DIR)/bin/tracemeshd --molecules $(TRACEMESH_MOLECULES_DIR) $(SOAK_ARGS)

# Scaling out: a mixed job stream through nginx to 1 and 2 replicas (Redis, one core each) and cache-hit GETs through
# nginx vs one replica (bench/replicas_bench.py: REPLICAS_ARGS="--ladder fas2.pqr,mache.pqr --densities 1" ...).
bench-replicas: build
	python3 bench/replicas_bench.py --daemon $(BUILD_DIR)/bin/tracemeshd --molecules $(TRACEMESH_MOLECULES_DIR) $(REPLICAS_ARGS)

# Chaos: 100 rounds of kill -9 at seeded random moments while jobs run and uploads stream (10 run in `make test`).
CHAOS_ROUNDS ?= 100
bench-chaos: build
	cd $(BUILD_DIR) && TRACEMESH_CHAOS_ROUNDS=$(CHAOS_ROUNDS) $(if $(CHAOS_SEED),TRACEMESH_CHAOS_SEED=$(CHAOS_SEED)) \
	  ./bin/integration_tests --gtest_filter='*ChaosKill9*'

# The paper reproduction: bench/paper/report.md and its figures (PAPER_MAX_ATOMS=20000 for a quick run).
bench-paper: build
	@bash scripts/install-deps.sh --bench-paper
	BUILD_DIR=$(BUILD_DIR) bash bench/run_paper.sh

# tracemesh against NanoShaper's Blobby surface at the same vertex count (bench/nanoshaper_bench.py; NANOSHAPER=the
# binary, skipped without it; docs/benchmarks.md says how to build one). Needs the large molecules.
bench-nanoshaper: build
	TRACEMESH=$(BUILD_DIR)/bin/tracemesh python3 bench/nanoshaper_bench.py $(NANOSHAPER_ARGS)

# Seconds, field evaluations, instructions and allocations per stage of the trace path (bench/stage_table.py).
bench-stages: build
	TRACEMESH=$(BUILD_DIR)/bin/tracemesh python3 bench/stage_table.py $(STAGES_ARGS)

# Robustness of the trace path at sharp kernels: where each mesh came from (line grid or lattice path) over d x t0 x
# density (bench/sharp_kernel_sweep.py: SHARP_ARGS="--baseline OLD/tracemesh --molecules fas2" ...).
bench-sharp: build
	python3 bench/sharp_kernel_sweep.py --tracemesh $(BUILD_DIR)/bin/tracemesh --out $(BUILD_DIR)/bench $(SHARP_ARGS)

# Real fuzzing with clang-14 libFuzzer (not part of the suite; the seed corpora replay in `make test`).
fuzz: deps
	CXX=clang++-14 cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=CI -DTRACEMESH_BUILD_FUZZERS=ON -DTRACEMESH_SANITIZE="address;undefined" -DTRACEMESH_BUILD_BENCH=OFF
	cmake --build build-fuzz -j $(JOBS)

# The container image (docker/Dockerfile) with docker or podman, and its smoke test (tests/image/smoke_test.sh).
# Not part of `make test`: the image build compiles the whole project inside (minutes).
IMAGE            ?= localhost/tracemesh:latest
image:
	@bash scripts/install-deps.sh --image
	BUILD_JOBS=$(JOBS) bash scripts/build-image.sh $(IMAGE)

test-image: image
	bash tests/image/smoke_test.sh $(IMAGE)

# The fuzz campaign: each fuzz target FUZZ_RUNS executions (default 10^7; FUZZ_RUNS=100000 for a short run,
# FUZZ_TARGETS="pqr_reader gzip_body" for some, FUZZ_JOBS=2 for two targets at once); new coverage is merged into
# tests/fuzz/corpus/<name>/ and every crash kept there as a regression input (scripts/fuzz_campaign.sh; summary in
# build-fuzz/campaign/summary.md). On a shared machine: `nice -n 19 make fuzz-campaign FUZZ_JOBS=2`.
FUZZ_TARGET_NAMES = $(patsubst tests/fuzz/%.cpp,%,$(wildcard tests/fuzz/*_fuzzer.cpp))
fuzz-campaign: deps
	CXX=clang++-14 cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=CI -DTRACEMESH_BUILD_FUZZERS=ON -DTRACEMESH_SANITIZE="address;undefined" -DTRACEMESH_BUILD_BENCH=OFF $(CMAKE_FLAGS)
	cmake --build build-fuzz -j $(JOBS) --target $(FUZZ_TARGET_NAMES)
	BUILD_DIR=build-fuzz bash scripts/fuzz_campaign.sh

clean:
	rm -rf $(BUILD_DIR) $(SANITIZE_DIR) $(TSAN_DIR) build-fuzz
