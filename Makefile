# pointatlas: `make demo` and `make test` set everything up on a fresh machine.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
DOCS_STAMP := $(VENV)/.docs-installed

.PHONY: install demo test bench lint docs clean clean-numba

# OpenBLAS' AVX2 kernels on every x86-64 CPU (it picks AVX-512 ones where it can: the
# same products rounded apart): the same bits on every machine, tests and benchmarks
# alike (`import pointatlas` sets it too, when it comes before numpy's)
ifeq ($(shell uname -m),x86_64)
export OPENBLAS_CORETYPE ?= Haswell
endif

# constraints.txt: the exact versions the suite passed with (a new release of a
# dependency changes nothing unseen)
$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -c constraints.txt -e ".[dev]"
	@# compile every command's numba kernels into the cache now (a few minutes, once),
	@# so that a first command, and the tests, start at once (docs/decisions/cli.md)
	$(BIN)/pointatlas warmup
	touch $(STAMP)

install: $(STAMP)

demo: install
	$(BIN)/pointatlas demo --out demo-output

lint: install
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/ruff format --check src tests benchmarks
	$(BIN)/lint-imports

test: lint
	@# the report browser tests need Debian's chromium, Open3D's reader libusb; without
	@# them (no apt-get) those tests skip
	@command -v chromium >/dev/null || (apt-get install -y --no-install-recommends chromium \
		|| (apt-get update && apt-get install -y --no-install-recommends chromium) \
		|| echo "chromium not installed: browser tests will skip")
	@$(BIN)/python -c "import open3d" 2>/dev/null || (apt-get install -y --no-install-recommends \
		libusb-1.0-0 || (apt-get update && apt-get install -y --no-install-recommends \
		libusb-1.0-0) || echo "libusb not installed: Open3D reader tests will skip")
	@# one process: with pytest-xdist workers CI once hung for its whole 90 minutes
	@# (docs/decisions/cli.md); a test still running after `timeout` (pyproject.toml)
	@# fails the run with every thread's stack; the 20 slowest tests close the log (the
	@# suite's 10-minute target: what to look at first)
	$(BIN)/python -m pytest -q --durations=20

bench: install
	$(BIN)/python -m pip install --quiet -c constraints.txt -e ".[dev,bench]"
	for b in neighbors io normals features vsa simplify viz synth batch; do \
		$(BIN)/python benchmarks/bench_$$b.py || exit 1; \
	done

# the API reference into build/docs, warnings as errors (docs/decisions/docs.md); needs
# only the docs extra, not the numba cache that `install` fills
$(DOCS_STAMP): pyproject.toml constraints.txt
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet -c constraints.txt -e ".[docs]"
	touch $(DOCS_STAMP)

docs: $(DOCS_STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --clean

clean: clean-numba
	rm -rf $(VENV) demo-output build *.egg-info

# numba's on-disk caches (CONTRIBUTING.md: a caller's cache does not see its callees' edits)
clean-numba:
	find src -name '*.nbi' -delete -o -name '*.nbc' -delete
