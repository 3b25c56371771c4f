# pointatlas: `make demo` and `make test` set everything up on a fresh machine.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: install demo test bench lint clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[dev]"
	touch $(STAMP)

install: $(STAMP)

demo: install
	$(BIN)/pointatlas demo --out demo-output

lint: install
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/lint-imports

test: lint
	@# the report browser tests need Debian's chromium; without it (no apt-get) they skip
	@command -v chromium >/dev/null || (apt-get install -y --no-install-recommends chromium \
		|| (apt-get update && apt-get install -y --no-install-recommends chromium) \
		|| echo "chromium not installed: browser tests will skip")
	$(BIN)/python -m pytest -q

bench: install
	$(BIN)/python -m pip install --quiet -e ".[dev,bench]"
	for b in neighbors io normals features vsa simplify viz synth batch; do \
		$(BIN)/python benchmarks/bench_$$b.py || exit 1; \
	done

clean:
	rm -rf $(VENV) demo-output build *.egg-info
