# Developer entry points. `make test` is the whole suite: the overflow-checked Rust tests, then the Python tests
# against the release wheel of this tree, installed into ./.venv (created if missing). Each profile is compiled
# once: `test-checked` for the Rust tests, `release` for the wheel (which `pip install .` shares via target/).
VENV ?= .venv
PY := $(VENV)/bin/python
# Extra flags of the wheel build; CI uses --zig --compatibility manylinux2014 (the wheel a package index takes).
WHEEL_FLAGS ?=
.DEFAULT_GOAL := all

.PHONY: all install wheel sdist test test-rust test-python lint lint-python stubtest bench bench-compare publish-check clean

all: lint test

$(PY):
	python3 -m venv $(VENV)

## The release wheel of this tree in dist/ (abi3: one wheel for every Python >= 3.10).
# With --zig in WHEEL_FLAGS the venv gets ziglang (PyPI), which maturin finds as `python3 -m ziglang` on PATH.
wheel: $(PY)
	$(PY) -m pip install --quiet "maturin>=1.9.4,<2" $(if $(findstring --zig,$(WHEEL_FLAGS)),ziglang)
	rm -f dist/tilesynth-*.whl
	PATH="$(abspath $(VENV))/bin:$$PATH" $(VENV)/bin/maturin build --release --quiet $(WHEEL_FLAGS) -o dist

sdist: $(PY)
	$(PY) -m pip install --quiet "maturin>=1.9.4,<2"
	$(VENV)/bin/maturin sdist -o dist

## Install the wheel (built if missing) with the test extras into $(VENV).
install: $(PY)
	test -n "$$(ls dist/tilesynth-*.whl 2>/dev/null)" || $(MAKE) wheel
	$(PY) -m pip install --quiet --force-reinstall --no-deps dist/tilesynth-*.whl
	$(PY) -m pip install --quiet "$$(ls dist/tilesynth-*.whl)[test]"

## The whole test suite: Rust unit tests, then pytest against the installed wheel.
test: test-rust test-python

## Rust tests with overflow checks and debug assertions on (the test-checked profile of Cargo.toml).
test-rust:
	cargo test -p tilesynth --profile test-checked

test-python: wheel install
	$(PY) -m pytest -q

## Rust: fmt and clippy (with and without the Python bindings); Python: ruff and the stub check.
lint: lint-python stubtest
	cargo fmt --check
	cargo clippy --all-targets -- -D warnings
	cargo clippy --all-targets --features python -- -D warnings

## ruff (configured in pyproject.toml) over the package, the tests and the benches.
lint-python: install
	$(PY) -m ruff check python tests benches
	$(PY) -m ruff format --check python tests benches

## python/tilesynth/_core.pyi against the compiled module (mypy's stubtest; needs the installed wheel).
stubtest: install
	$(PY) -m mypy.stubtest tilesynth._core

## Criterion benches (size sweeps), then the side-by-side comparison with the Python baselines.
bench:
	cargo bench

bench-compare: install
	$(PY) -m pip install --quiet ".[bench]"
	$(PY) benches/compare.py

## Before an upload (README, "Publish"): pyproject.toml must name the project's public addresses ([project.urls],
# none today: the address is not known yet and must not be invented), and twine must accept dist/*.
publish-check: $(PY)
	$(PY) -c "import sys; tl = __import__('tomllib' if sys.version_info >= (3, 11) else 'tomli'); \
	urls = tl.load(open('pyproject.toml', 'rb'))['project'].get('urls') or {}; \
	sys.exit(None if urls.get('Repository') else 'pyproject.toml: add [project.urls] with at least Repository (README, Publish, step 0) before uploading')"
	test -n "$$(ls dist/tilesynth-* 2>/dev/null)" || { echo "dist/ is empty: run .ci/run (README, Publish, step 2)"; exit 1; }
	$(PY) -m pip install --quiet twine
	$(VENV)/bin/twine check dist/*

clean:
	cargo clean
	rm -rf .pytest_cache .hypothesis dist
