# tracemesh — the four entry points of DEVELOPERS.md. Everything else is CMake.
BUILD_DIR        ?= build
SANITIZE_DIR     ?= build-asan
JOBS             ?= $(shell nproc)
LISTEN           ?= 127.0.0.1:8080
CACHE_DIR        ?= $(CURDIR)/cache
CMAKE_FLAGS      ?=

.PHONY: deps build test test-sanitize run bench bench-paper fuzz image test-image clean

deps:
	@bash scripts/install-deps.sh

build: deps
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)
	cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) --timeout 900

# The AddressSanitizer + UndefinedBehaviorSanitizer configuration (CI runs it after `make test`).
test-sanitize: deps
	cmake -S . -B $(SANITIZE_DIR) -DCMAKE_BUILD_TYPE=CI -DTRACEMESH_SANITIZE="address;undefined" -DTRACEMESH_BUILD_BENCH=OFF $(CMAKE_FLAGS)
	cmake --build $(SANITIZE_DIR) -j $(JOBS)
	cd $(SANITIZE_DIR) && TRACEMESH_SANITIZED=1 ctest --output-on-failure -j $(JOBS) --timeout 1800

run: build
	@if [ -x $(BUILD_DIR)/bin/tracemeshd ]; then \
	  mkdir -p $(CACHE_DIR) && exec $(BUILD_DIR)/bin/tracemeshd --listen $(LISTEN) --cache-dir $(CACHE_DIR); \
	else \
	  $(BUILD_DIR)/bin/tracemesh tests/data/example.pqr -o example.off --report -; \
	fi

# The molecule ladder, lattice vs trace (bench/run_ladder.sh: RUNS, MAX_ATOMS, MOLECULES, THREADS...).
bench: build
	BUILD_DIR=$(BUILD_DIR) bash bench/run_ladder.sh

# The paper reproduction: bench/paper/report.md and its figures (PAPER_MAX_ATOMS=20000 for a quick run).
bench-paper: build
	@bash scripts/install-deps.sh --bench-paper
	BUILD_DIR=$(BUILD_DIR) bash bench/run_paper.sh

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

clean:
	rm -rf $(BUILD_DIR) $(SANITIZE_DIR) build-fuzz
