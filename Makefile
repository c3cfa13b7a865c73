# Set-up is two commands: `make demo` and `make test`. Both create .venv when missing.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp

.PHONY: demo test test-fast lint bench docs clean system-packages bytecode

# uv installs what pip would, in a fifth of pip's time; pip where uv cannot. Both
# compile the packages' bytecode as they install: a machine with PYTHONDONTWRITEBYTECODE
# set never writes it later, and every process would compile numpy, pandas, Ray... again
$(STAMP): pyproject.toml setup.py sdc/car/_geometry_kernels.c scenarios/scene/_road_kernels.c scenarios/scene/*.h  # C builds at install (optional)
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet uv
	$(BIN)/uv pip install --quiet --compile-bytecode --python $(BIN)/python -e '.[dev]' \
		|| $(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

# sdc's own bytecode, fresh before each use (for the same reason; under a second)
bytecode: $(STAMP)
	$(BIN)/python -m compileall -q -j 0 sdc scenarios analysis benchmarks

demo: $(STAMP) bytecode
	$(BIN)/sdc demo

# pytest's cache (what --lf reads) is not written: it cost the suite about 50 s here
test: $(STAMP) bytecode system-packages
	$(BIN)/ruff check .
	$(BIN)/lint-imports
	$(BIN)/python -m pytest -n 2 --dist worksteal -q -p no:cacheprovider

test-fast: $(STAMP) bytecode
	$(BIN)/python -m pytest -n 2 --dist worksteal -q -p no:cacheprovider -m 'not slow'

# the manual: site/index.html, from docs/ and mkdocs.yml; warnings are errors
docs: $(STAMP)
	$(BIN)/mkdocs build --strict --site-dir site

system-packages:
	.ci/install-system-packages

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/lint-imports

bench: $(STAMP)
	$(BIN)/python benchmarks/bench_sweep.py
	$(BIN)/python benchmarks/bench_town.py
	$(BIN)/python benchmarks/bench_shared_worlds.py
	$(BIN)/python benchmarks/bench_gym.py
	$(BIN)/python benchmarks/bench_perf.py
	$(BIN)/python benchmarks/bench_world.py
	$(BIN)/python benchmarks/bench_people.py
	$(BIN)/python benchmarks/bench_controllers.py
	$(BIN)/python benchmarks/bench_rare.py
	$(BIN)/python benchmarks/bench_rare_bank.py

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache .hypothesis build site
	find sdc scenarios -name '*.so' -delete
