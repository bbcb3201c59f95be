# SPDX-License-Identifier: MIT
# somm — top-level driver. Every target installs missing Debian packages first (we run as root on Debian bookworm).
BUILD      ?= build
ASAN_BUILD ?= build-asan
FUZZ_BUILD ?= build-fuzz
JOBS       ?= $(shell nproc)
SECONDS    ?= 30
CMAKE_GEN  := -G Ninja

# Debian packages, per what needs them (docs/integration.md lists the same): every target installs only its own.
PKGS_BASE  := cmake ninja-build g++ pkg-config
PKGS_LIB   := libtbb-dev                                       # somm::somm (the baker's threads)
PKGS_IO    := libtinygltf-dev libtinyobjloader-dev libstb-dev libdeflate-dev libxxhash-dev   # somm::io
PKGS_TRACE := libembree-dev                                    # somm::trace
PKGS_CLI   := libcli11-dev nlohmann-json3-dev libzstd-dev liblzma-dev
PKGS_TEST  := libgtest-dev libgmock-dev
PKGS_BENCH := libbenchmark-dev
PKGS_GPU   := libvulkan-dev libvulkan1 glslang-tools mesa-vulkan-drivers  # somm_gpu: build + lavapipe to test
PKGS_FUZZ  := clang libclang-rt-14-dev                         # make fuzz only (~200 MB)
PKGS_LINT  := clang-format clang-tidy                          # make format / lint only
PKGS_DEMO  := $(PKGS_BASE) $(PKGS_LIB) $(PKGS_IO) $(PKGS_TRACE) $(PKGS_CLI)
PKGS_ALL   := $(PKGS_DEMO) $(PKGS_TEST) $(PKGS_BENCH) $(PKGS_GPU)
DEB_PKGS   := $(PKGS_ALL) $(PKGS_FUZZ) $(PKGS_LINT)            # everything (make deps)

# $(call install_pkgs,LIST): apt-get install the missing ones.
define install_pkgs
	@missing=""; for p in $(1); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "somm: installing Debian packages:$$missing"; \
	  export DEBIAN_FRONTEND=noninteractive; \
	  apt-get install -y -qq $$missing >/dev/null 2>&1 || { apt-get update -qq && apt-get install -y -qq $$missing; }; \
	fi
endef

CONFIGURE_ALL := cmake -S . -B $(BUILD) $(CMAKE_GEN) -DCMAKE_BUILD_TYPE=Release -DSOMM_BUILD_CLI=ON \
                 -DSOMM_BUILD_TRACE=ON -DSOMM_BUILD_TESTS=ON -DSOMM_BUILD_BENCH=ON -DSOMM_BUILD_GPU=ON

.PHONY: all deps deps-demo deps-all deps-fuzz deps-lint configure build test sanitize fuzz fuzz-build bench demo format lint clean

all: build

deps:
	$(call install_pkgs,$(DEB_PKGS))
deps-demo:
	$(call install_pkgs,$(PKGS_DEMO))
deps-all:
	$(call install_pkgs,$(PKGS_ALL))
deps-lint:
	$(call install_pkgs,$(PKGS_LINT))
deps-fuzz:
	$(call install_pkgs,$(PKGS_BASE) $(PKGS_LIB) $(PKGS_IO) $(PKGS_CLI) $(PKGS_FUZZ))

configure: deps-all
	$(CONFIGURE_ALL)

build: configure
	cmake --build $(BUILD) -j $(JOBS)

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

sanitize: deps-all
	cmake -S . -B $(ASAN_BUILD) $(CMAKE_GEN) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSOMM_SANITIZE=ON -DSOMM_BUILD_BENCH=OFF \
	  -DSOMM_BUILD_GPU=ON
	cmake --build $(ASAN_BUILD) -j $(JOBS)
	cd $(ASAN_BUILD) && ASAN_OPTIONS=detect_leaks=1:abort_on_error=0 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
	  ctest --output-on-failure -j $(JOBS)

# libFuzzer targets (clang, ASan+UBSan, separate build dir): each runs SECONDS seconds (docs/hardening.md).
fuzz-build: deps-fuzz
	cmake -S . -B $(FUZZ_BUILD) $(CMAKE_GEN) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
	  -DCMAKE_C_COMPILER=clang -DSOMM_BUILD_FUZZ=ON -DSOMM_BUILD_TESTS=OFF -DSOMM_BUILD_BENCH=OFF -DSOMM_BUILD_TRACE=OFF \
	  -DSOMM_BUILD_GPU=OFF
	cmake --build $(FUZZ_BUILD) -j $(JOBS) --target somm_fuzzers

fuzz: fuzz-build
	bash fuzz/run.sh $(FUZZ_BUILD) $(SECONDS)

bench: build
	$(BUILD)/bench/somm_bench --benchmark_counters_tabular=true

# The demo needs the CLI alone: a first configuration of $(BUILD) leaves the tests and benchmarks out (their
# packages are not installed); an existing one is kept. Only the `somm` target is built.
demo: deps-demo
	@if [ ! -f $(BUILD)/build.ninja ]; then \
	  cmake -S . -B $(BUILD) $(CMAKE_GEN) -DCMAKE_BUILD_TYPE=Release -DSOMM_BUILD_CLI=ON -DSOMM_BUILD_TRACE=ON \
	    -DSOMM_BUILD_TESTS=OFF -DSOMM_BUILD_BENCH=OFF -DSOMM_BUILD_GPU=OFF; \
	fi
	cmake --build $(BUILD) -j $(JOBS) --target somm
	bash tools/demo.sh $(BUILD)/tools/somm/somm

# Our C/C++ sources (shaders are not clang-formatted).
FORMAT_FILES = $(shell git ls-files -- '*.c' '*.cpp' '*.h' ':!:shaders/*')
# clang-tidy (.clang-tidy: bugprone-*, performance-*) over the library and the CLI, with their headers.
TIDY_FILES := '$(CURDIR)/(src|tools)/'

format: deps-lint
	clang-format -i $(FORMAT_FILES)

# CI: fails on any clang-format change or clang-tidy finding (needs the build dir's compile_commands.json).
lint: deps-lint
	clang-format --dry-run -Werror $(FORMAT_FILES)
	@if [ ! -f $(BUILD)/compile_commands.json ]; then $(MAKE) configure; fi
	run-clang-tidy -p $(BUILD) -quiet -j $(JOBS) $(TIDY_FILES) > $(BUILD)/clang-tidy.log 2>&1 || \
	  { grep -E 'error:|warning:' $(BUILD)/clang-tidy.log | sed 's/\x1b\[[0-9;]*m//g' | sort -u; exit 1; }
	@echo "clang-format and clang-tidy: clean"

clean:
	rm -rf $(BUILD) $(ASAN_BUILD) $(FUZZ_BUILD)
