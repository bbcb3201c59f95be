# SPDX-License-Identifier: MIT
# somm — top-level driver. Every target installs missing Debian packages first (we run as root on Debian bookworm).
BUILD      ?= build
ASAN_BUILD ?= build-asan
FUZZ_BUILD ?= build-fuzz
JOBS       ?= $(shell nproc)
SECONDS    ?= 30
CMAKE_GEN  := -G Ninja

DEB_PKGS := cmake ninja-build g++ pkg-config libgtest-dev libgmock-dev libbenchmark-dev \
            libtinygltf-dev libtinyobjloader-dev libstb-dev libembree-dev libtbb-dev libcli11-dev \
            nlohmann-json3-dev libxxhash-dev libzstd-dev liblzma-dev clang libclang-rt-14-dev

.PHONY: all deps configure build test sanitize fuzz fuzz-build bench demo format clean

all: build

deps:
	@missing=""; for p in $(DEB_PKGS); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "somm: installing Debian packages:$$missing"; \
	  export DEBIAN_FRONTEND=noninteractive; \
	  apt-get install -y -qq $$missing >/dev/null 2>&1 || { apt-get update -qq && apt-get install -y -qq $$missing; }; \
	fi

$(BUILD)/build.ninja: | deps
	cmake -S . -B $(BUILD) $(CMAKE_GEN) -DCMAKE_BUILD_TYPE=Release

configure: deps $(BUILD)/build.ninja

build: configure
	cmake --build $(BUILD) -j $(JOBS)

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

sanitize: deps
	cmake -S . -B $(ASAN_BUILD) $(CMAKE_GEN) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSOMM_SANITIZE=ON -DSOMM_BUILD_BENCH=OFF
	cmake --build $(ASAN_BUILD) -j $(JOBS)
	cd $(ASAN_BUILD) && ASAN_OPTIONS=detect_leaks=1:abort_on_error=0 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
	  ctest --output-on-failure -j $(JOBS)

# libFuzzer targets (clang, ASan+UBSan, separate build dir): each runs SECONDS seconds (docs/hardening.md).
fuzz-build: deps
	cmake -S . -B $(FUZZ_BUILD) $(CMAKE_GEN) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
	  -DSOMM_FUZZ=ON -DSOMM_BUILD_TESTS=OFF -DSOMM_BUILD_BENCH=OFF -DSOMM_BUILD_TRACE=OFF
	cmake --build $(FUZZ_BUILD) -j $(JOBS) --target somm_fuzzers

fuzz: fuzz-build
	bash fuzz/run.sh $(FUZZ_BUILD) $(SECONDS)

bench: build
	$(BUILD)/bench/somm_bench --benchmark_counters_tabular=true

demo: build
	bash tools/demo.sh $(BUILD)/tools/somm/somm

format:
	@command -v clang-format >/dev/null || apt-get install -y -qq clang-format
	find include src tools tests bench fuzz -name '*.h' -o -name '*.cpp' | xargs clang-format -i

clean:
	rm -rf $(BUILD) $(ASAN_BUILD) $(FUZZ_BUILD)
