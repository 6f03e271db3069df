# Developer entry points. `make test` is the whole suite (Rust, then the Python package built from this tree).
PYTHON ?= python3
.DEFAULT_GOAL := all

.PHONY: all install test test-rust test-python lint lint-python stubtest bench bench-compare clean

all: lint test

## Build and install the package (release) with the test extras.
install:
	$(PYTHON) -m pip install --quiet ".[test]"

## The whole test suite: Rust unit tests, then pytest against the installed build of this tree.
test: test-rust test-python

## Rust tests with overflow checks and debug assertions on (the test-checked profile of Cargo.toml).
test-rust:
	cargo test --profile test-checked

test-python: install
	$(PYTHON) -m pytest -q

## Rust: fmt and clippy (with and without the Python bindings); Python: ruff and the stub check.
lint: lint-python stubtest
	cargo fmt --check
	cargo clippy --all-targets -- -D warnings
	cargo clippy --all-targets --features python -- -D warnings

## ruff (configured in pyproject.toml) over the package, the tests and the benches.
lint-python:
	$(PYTHON) -m ruff check python tests benches
	$(PYTHON) -m ruff format --check python tests benches

## python/tilesynth/_core.pyi against the compiled module (mypy's stubtest; needs the installed build).
stubtest: install
	$(PYTHON) -m mypy.stubtest tilesynth._core

## Criterion benches (size sweeps), then the side-by-side comparison with the Python baselines.
bench:
	cargo bench

bench-compare: install
	$(PYTHON) -m pip install --quiet ".[bench]"
	$(PYTHON) benches/compare.py

clean:
	cargo clean
	rm -rf .pytest_cache .hypothesis
