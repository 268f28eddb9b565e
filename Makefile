# synthcompose - `make help` lists the targets.
SHELL := bash
.SHELLFLAGS := -eu -o pipefail -c
.DEFAULT_GOAL := help
MAKEFLAGS += --no-builtin-rules

PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
SAMPLE := assets/demo/cityscapes
SAMPLE_COUNT ?= 3

.PHONY: help system venv sample demo test check lint bench clean

help: ## show this help
	@grep -hE '^[a-z-]+:.*## ' $(MAKEFILE_LIST) | awk -F':.*## ' '{printf "  make %-8s %s\n", $$1, $$2}'

system: ## install system packages (Mesa EGL, assimp) when missing
	@bash scripts/system-deps.sh

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test,ray]'
	touch $@

venv: $(VENV)/.installed ## create the virtualenv with the package and test tools

$(SAMPLE)/.complete: | $(VENV)/.installed
	$(VENV)/bin/synthcompose make-sample $(SAMPLE) --count $(SAMPLE_COUNT)
	touch $@

sample: system venv $(SAMPLE)/.complete ## generate the bundled sample image sets if absent

demo: system venv sample ## run the main job on the bundled sample
	$(VENV)/bin/synthcompose batch assets/demo/manifest.json
	@echo "results: out/demo (images under leftImg8bit/, rightImg8bit/, gtFine/, disparity/; records under synthcompose/)"

test: system venv lint ## run the whole test suite (the linter, then every test; CI runs this)
	@bash scripts/system-deps.sh --test
	$(PY) -m pytest

check: system venv lint ## the fast tier: every test not marked slow (a few minutes)
	@bash scripts/system-deps.sh --test
	$(PY) -m pytest -m "not slow" -n auto

lint: venv ## ruff: line length and import order (pyproject.toml)
	$(VENV)/bin/ruff check synthcompose evaluation tests benchmarks scripts

clean: ## remove generated outputs (keeps the virtualenv)
	rm -rf out $(SAMPLE)

bench: system venv ## CPU-s per image set vs the PNG codec's (the headline), per stage, per worker count; speed and collision costs
	$(PY) benchmarks/bench_cost.py $(if $(REAL),--real $(REAL))
	$(PY) benchmarks/bench_pipeline.py
	$(PY) benchmarks/bench_collision.py
