# MiniSkeleton: the two commands are `make demo` and `make test`; everything else is a step of them.
# Each target sets up what it needs (virtualenv, bpy from PyPI, Rust build), so a fresh clone works.

SHELL      := /bin/bash
PYTHON     ?= $(shell command -v python3.11 || command -v python3)
VENV       ?= .venv
VPY        := $(VENV)/bin/python
BUILD      := $(PYTHON) scripts/platforms/build.py
# The platforms and wheels are the manifest's (addon/blender_manifest.toml); HOST is this machine.
PLATFORMS  := $(shell $(BUILD) platforms)
HOST       := linux-x64
WHEEL      := $(shell $(BUILD) wheels $(HOST))
EXT_ZIP    := $(shell $(BUILD) zips $(HOST))
ALL_ZIPS   := $(shell $(BUILD) zips)
BPY_42     ?= 4.2.23
BPY_45     ?= 4.5.15
MODEL      ?=
PUPPET     ?=
export CARGO_TERM_COLOR ?= never
export MINISKELETON_EXTENSION_ZIP := $(abspath $(EXT_ZIP))

RUST_SRC   := $(shell find rust -name '*.rs' -o -name Cargo.toml) Cargo.toml Cargo.lock pyproject.toml
ADDON_SRC  := $(shell find addon -name '*.py' -o -name '*.toml')

.PHONY: all demo test test-rust test-python test-platforms test-blender test-blender-4.2 test-blender-4.5 \
    extension wheel venv bench fuzz clean

all: extension

## Virtualenv with bpy, numpy, pytest, maturin (pip's cache makes reruns fast).
venv: $(VENV)/.installed
$(VENV)/.installed: requirements-dev.txt
	test -x $(VPY) || $(PYTHON) -m venv $(VENV)
	$(VPY) -m pip install --upgrade --quiet pip
	$(VPY) -m pip install --quiet -r requirements-dev.txt
	touch $@

## The core's wheel for each platform into addon/wheels/ (abi3-py311): this machine's with
## rustup's toolchain and zig (manylinux_2_28), Windows and macOS cross-built with Debian's
## rustc-web and -Zbuild-std (scripts/platforms/toolchain.sh installs the pinned packages).
## One zip per platform in dist/, built by Blender's own builder (--split-platforms).
## `make demo` and the test-* targets below need only this machine's wheel and zip.
define PLATFORM_RULES
$(shell $(BUILD) wheels $(1)): $(VENV)/.installed $(RUST_SRC) miniskeleton_core.pyi scripts/platforms/build.py \
    $(if $(filter $(1),$(HOST)),,scripts/platforms/toolchain.sh)
	$(VPY) scripts/platforms/build.py wheel $(1)
$(shell $(BUILD) zips $(1)): $(shell $(BUILD) wheels $(1)) $(ADDON_SRC) scripts/platforms/build.py
	$(VPY) scripts/platforms/build.py pack $(1)
endef
$(foreach p,$(PLATFORMS),$(eval $(call PLATFORM_RULES,$(p))))

wheel: $(WHEEL)
extension: $(ALL_ZIPS)

## tests/ import this machine's core from .build/core; the venv itself never has it, so the
## Blender tests can only find the copy bundled in the installed extension.
.build/core/.installed: $(WHEEL)
	rm -rf .build/core
	$(VPY) -m pip install --quiet --no-deps --target .build/core $<
	touch $@

## Headless demo: Spot the cow's bare mesh (assets/spot) auto-rigged, bound, animated, rendered
## (or MODEL=path: any mesh the same way, or a model with its armature; PUPPET=five-rod: puppets).
demo: $(EXT_ZIP)
	$(VPY) -m scripts.demo --out out $(if $(MODEL),--model $(MODEL)) $(if $(PUPPET),--puppet $(PUPPET))

## All tests: Rust, Python API, every platform's build, then Blender (installing the extension
## zip like a user) on 5.0.1 and on the oldest release the manifest allows, 4.2 LTS.
test: test-rust test-python test-platforms test-blender test-blender-4.2

test-rust:
	cargo fmt --all -- --check  # rustfmt.toml: 120 columns, as the code was written
	cargo clippy --all-targets --release -- -D warnings
	cargo test -p miniskeleton-core --release
	cargo fmt --manifest-path fuzz/Cargo.toml -- --check  # the fuzz targets (make fuzz) still build
	cargo check --quiet --manifest-path fuzz/Cargo.toml --bins

test-python: .build/core/.installed
	$(VPY) -m ruff check --quiet
	PYTHONPATH=.build/core $(VPY) -m mypy.stubtest miniskeleton_core \
	    --allowlist rust/python/stubtest-allowlist.txt
	PYTHONPATH=.build/core $(VPY) -m pytest -q tests

## Each platform's zip and wheel: tags, imports / load commands, panic strategy, contents,
## Blender's `extension validate`, and a repository index over all zips (release_tests/).
test-platforms: $(ALL_ZIPS)
	scripts/platforms/toolchain.sh
	$(VPY) -m pytest -q release_tests

test-blender: $(EXT_ZIP)
	$(VPY) -m pytest -q blender_tests

## The same Blender tests on the LTS releases 4.2 (in `make test`) and 4.5: bpy from PyPI in
## virtualenvs of their own, .venv-bpy42 and .venv-bpy45, made when missing or when BPY_42 /
## BPY_45 changes (the stamp names the version). bpy 4.2 and 4.5 exist for CPython 3.11 only.
define LTS_VENV
.venv-bpy$(1)/.installed-bpy-$(BPY_$(1)):
	@$(PYTHON) -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' || { echo \
	    "bpy $(BPY_$(1)) is built for CPython 3.11 only, and $(PYTHON) is not 3.11: make PYTHON=/path/to/python3.11" >&2; \
	    exit 1; }
	rm -rf .venv-bpy$(1)
	$(PYTHON) -m venv .venv-bpy$(1)
	.venv-bpy$(1)/bin/python -m pip install --quiet --upgrade pip
	.venv-bpy$(1)/bin/python -m pip install --quiet "bpy==$(BPY_$(1))" "numpy<2" "pytest>=8"
	touch $$@
endef
$(foreach v,42 45,$(eval $(call LTS_VENV,$(v))))

test-blender-4.2: .venv-bpy42/.installed-bpy-$(BPY_42)
test-blender-4.5: .venv-bpy45/.installed-bpy-$(BPY_45)
test-blender-4.2 test-blender-4.5: test-blender-%: $(EXT_ZIP)
	@# One pytest process per test file, and one per test of a file whose process died by a signal
	@# (Blender 4.2 segfaults at random late in a long run; see scripts/lts_tests.py and conftest).
	.venv-bpy$(subst .,,$*)/bin/python -m scripts.lts_tests

## Benchmarks (speed is measured here, never asserted in tests), run as modules from the checkout so
## that they import the helpers package testkit/ (whose measures the tests share) as they are.
bench: $(EXT_ZIP)
	cargo bench -p miniskeleton-core
	$(VPY) -m bench.bench_weights
	$(VPY) -m testkit.eval_weights
	$(VPY) -m bench.heat_ceiling
	$(VPY) -m bench.heat_memory
	$(VPY) -m testkit.eval_fit
	$(VPY) -m bench.bench_autorig
	$(VPY) -m bench.bench_keys
	$(VPY) -m testkit.motion_corpus
	$(VPY) -m bench.bench_video

## Coverage-guided fuzzing (cargo-fuzz, libFuzzer; fuzz/ is a crate outside the workspace, so
## `make test` and the cross builds never see it): each target in turn for FUZZ_SECONDS under
## nice, the committed seed corpus fuzz/corpus/T read, what it finds kept in .build/fuzz/T.
## A finding stops the run and is left in fuzz/artifacts/T.
FUZZ_SECONDS ?= 60
FUZZ_TARGETS ?= heat weights autorig fit motion ik2d mesh
fuzz:
	@for t in $(FUZZ_TARGETS); do \
	    mkdir -p .build/fuzz/$$t fuzz/corpus/$$t; \
	    (cd fuzz && RUSTC_BOOTSTRAP=1 nice -n 19 cargo fuzz run $$t ../.build/fuzz/$$t corpus/$$t -- \
	        -max_total_time=$(FUZZ_SECONDS) -rss_limit_mb=2048 -timeout=20 -print_final_stats=1) || exit 1; \
	done

clean:
	rm -rf dist addon/wheels out .build
