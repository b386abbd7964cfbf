# wmkit: the README's two commands are `make demo` and `make test`. Every target that builds or
# runs installs the Debian packages first (scripts/install-deps.sh, idempotent).
SHELL := /bin/bash
BUILD ?= build
JOBS ?= $(shell nproc)
BIN := $(BUILD)/bin
DEMO_DIR ?= data/demo
# make wpe [WPE_DIR=data/wpe]: policy evaluation in the world model, end to end (scripts/wpe.sh)
WPE_DIR ?= data/wpe
# make tokenize|train SHARDS=<train shards> VAL=<val shards> [RUN=runs/main]
#   [TOKENIZER_CONFIG=...] [DYNAMICS_CONFIG=...]
SHARDS ?=
VAL ?=
RUN ?= runs/main
TOKENIZER_CONFIG ?= configs/tokenizer/tiny.yaml
DYNAMICS_CONFIG ?= configs/dynamics/tiny.yaml
# make eval CHECKPOINTS="runs/a/dynamics runs/b/dynamics" DATA=<val shards> [TOKENS=<val tokens>]
#   [TOKENIZER=<tokenizer run>] [REPORTS=reports] [EVAL_ARGS=...]; make report REPORTS=...
CHECKPOINTS ?=
DATA ?=
TOKENS ?= $(RUN)/tokens/val
TOKENIZER ?= $(RUN)/tokenizer
REPORTS ?= reports
# make ablation [ABLATION_CONFIG=configs/ablation/tiny.yaml] [ABLATION_DIR=data/ablation]
ABLATION_CONFIG ?= configs/ablation/tiny.yaml
ABLATION_DIR ?= data/ablation
# make finetune [FINETUNE_CONFIG=configs/finetune/tiny.yaml] [FINETUNE_DIR=data/finetune]
FINETUNE_CONFIG ?= configs/finetune/tiny.yaml
FINETUNE_DIR ?= data/finetune
# make scaling [SCALING_CONFIG=configs/scaling/tiny.yaml] [SCALING_DIR=data/scaling]
SCALING_CONFIG ?= configs/scaling/tiny.yaml
SCALING_DIR ?= data/scaling
# make ingest RAW=<input> OUT=<dataset dir> FORMAT=rlds|hdf5|folder [SPLIT=train] [ARGS=...]
RAW ?=
OUT ?=
FORMAT ?= rlds
SPLIT ?= train
ARGS ?=
# make test-sanitize: core/ + ingest/ and their tests under ASan + UBSan, in SANITIZE_BUILD.
SANITIZE_BUILD ?= build-asan
# make fuzz [FUZZ_SECONDS=600] [FUZZ_TARGETS="shard tokens"]: each libFuzzer target (clang) runs
# FUZZ_SECONDS on its corpus in FUZZ_BUILD; exits non-zero on any crash (docs/testing.md; hdf5:
# libhdf5-internal failures that wm-ingest contains are listed, not failed).
FUZZ_BUILD ?= build-fuzz
FUZZ_SECONDS ?= 600
FUZZ_TARGETS ?= tfrecord example shard tokens hdf5 parquet lerobot_meta yaml_config
HARDENING_CONFIG := -DCMAKE_BUILD_TYPE=RelWithDebInfo -DWM_DATA_ONLY=ON -DWM_BUILD_BENCH=OFF
# make test-model-only: the GPU machines' configuration (WM_MODEL_ONLY: no OpenCV/PCL/Ceres/HDF5/
# protobuf, docs/gpu.md) built on the CPU in MODEL_BUILD, and the tests of the code it swaps in.
MODEL_BUILD ?= build-model
MODEL_ONLY_TESTS ?= ImageCodec|TrainTest|EncodeTest|Overfit|FrameScores
# ccache keys on relative paths below the checkout, so other clones and worktrees share hits;
# without NOHASHDIR it also hashes the working directory of every -g compile (the ASan and fuzz
# builds, RelWithDebInfo), and a clone at a new path missed all of those (docs/testing.md).
export CCACHE_BASEDIR ?= $(CURDIR)
export CCACHE_NOHASHDIR ?= 1

.PHONY: all deps configure build test test-sanitize test-model-only fuzz demo wpe ingest tokenize train eval report ablation finetune scaling bench format lint clean

all: build

deps:
	@bash scripts/install-deps.sh

configure: deps
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release > /dev/null

build: configure
	@cmake --build $(BUILD) -j $(JOBS)

test: build
	@cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

test-sanitize: deps
	@cmake -S . -B $(SANITIZE_BUILD) $(HARDENING_CONFIG) -DWM_SANITIZE=ON > /dev/null
	@cmake --build $(SANITIZE_BUILD) -j $(JOBS)
	@# --timeout: a hung test (e.g. a forked child deadlocked in ASan's allocator) fails by name
	@cd $(SANITIZE_BUILD) && ctest --output-on-failure -j $(JOBS) --timeout 600

test-model-only: deps
	@cmake -S . -B $(MODEL_BUILD) -DCMAKE_BUILD_TYPE=Release -DWM_MODEL_ONLY=ON -DWM_BUILD_BENCH=OFF > /dev/null
	@cmake --build $(MODEL_BUILD) -j $(JOBS)
	@cd $(MODEL_BUILD) && ctest --output-on-failure -j $(JOBS) -R '$(MODEL_ONLY_TESTS)'

fuzz:
	@bash scripts/install-deps.sh clang libclang-rt-dev
	@cmake -S . -B $(FUZZ_BUILD) $(HARDENING_CONFIG) -DWM_FUZZ=ON -DWM_BUILD_TESTS=OFF \
	  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ > /dev/null
	@cmake --build $(FUZZ_BUILD) -j $(JOBS) --target wm_fuzzers wm-ingest
	@bash tests/fuzz/run.sh $(FUZZ_BUILD)/bin $(FUZZ_BUILD)/fuzz $(FUZZ_SECONDS) $(FUZZ_TARGETS)

# Only the demo's executables (CMake target wm_demo_tools), not the tests: a first run builds less.
demo: configure
	@cmake --build $(BUILD) -j $(JOBS) --target wm_demo_tools
	@bash scripts/demo.sh $(BIN) $(DEMO_DIR)

wpe: build
	@bash scripts/wpe.sh $(BIN) $(WPE_DIR)

ingest: build
	@if [ -z "$(RAW)" ] || [ -z "$(OUT)" ]; then \
	  echo "usage: make ingest RAW=<input> OUT=<dataset dir> FORMAT=rlds|hdf5|folder [SPLIT=train] [ARGS='--resize 128x128']"; exit 2; fi
	@$(BIN)/wm-ingest --format $(FORMAT) --input $(RAW) --output $(OUT) --split $(SPLIT) $(ARGS)
	@$(BIN)/wm-shard verify $(OUT)

tokenize train: build
	@if [ -z "$(SHARDS)" ] || [ -z "$(VAL)" ]; then \
	  echo "usage: make $@ SHARDS=<train shards> VAL=<val shards> [RUN=runs/main] [TOKENIZER_CONFIG=...] [DYNAMICS_CONFIG=...]"; exit 2; fi
	@TOKENS_ONLY=$(if $(filter tokenize,$@),1,0) bash scripts/train.sh $(BIN) $(RUN) $(SHARDS) $(VAL) \
	  $(TOKENIZER_CONFIG) $(DYNAMICS_CONFIG)

eval: build
	@if [ -z "$(CHECKPOINTS)" ] || [ -z "$(DATA)" ]; then \
	  echo "usage: make eval CHECKPOINTS=\"runs/a/dynamics runs/b/dynamics\" DATA=<val shards> [TOKENS=...] [TOKENIZER=...] [REPORTS=reports]"; exit 2; fi
	@bash scripts/eval.sh $(BIN) $(REPORTS) $(TOKENIZER) $(DATA) $(TOKENS) $(CHECKPOINTS)

report: build
	@$(BIN)/wm-report compare $$(find $(REPORTS) -mindepth 2 -maxdepth 2 -name manifest.json -printf '%h\n' | sort) \
	  --out $(REPORTS)/compare.csv --markdown $(REPORTS)/compare.md && cat $(REPORTS)/compare.md

ablation: build
	@/usr/bin/python3 scripts/ablation.py --bin $(BIN) --config $(ABLATION_CONFIG) --out $(ABLATION_DIR)

finetune: build
	@/usr/bin/python3 scripts/finetune.py --bin $(BIN) --config $(FINETUNE_CONFIG) --out $(FINETUNE_DIR)

scaling: build
	@/usr/bin/python3 scripts/scaling.py --bin $(BIN) --config $(SCALING_CONFIG) --out $(SCALING_DIR)

bench: build
	@cmake --build $(BUILD) -j $(JOBS) --target benchmarks
	@bash bench/run.sh $(BIN)

format:
	@git ls-files '*.cc' '*.h' | xargs clang-format -i

lint: configure
	@git ls-files '*.cc' | grep -v '^tests/' | xargs clang-tidy -p $(BUILD) --quiet

clean:
	@rm -rf $(BUILD) $(SANITIZE_BUILD) $(FUZZ_BUILD) $(DEMO_DIR)
