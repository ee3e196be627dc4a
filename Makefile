# riverflow: `make demo`, `make test`. Works from a fresh clone: the first target that needs
# Python creates $(VENV) with python3's venv module and installs the package with its test,
# plot, gis, hosts and cluster extras; it reinstalls when pyproject.toml changes.

VENV ?= .venv
PY := $(VENV)/bin/python
PYTHON ?= python3

# Python keeps each module it compiles (__pycache__): some machines set PYTHONDONTWRITEBYTECODE,
# and then every test process compiles numba, scipy, shapely, pyglet and the tests again
# (collecting the tests: 10 s of CPU a worker instead of 4).
export PYTHONDONTWRITEBYTECODE :=

# Compiled kernels are kept by the package itself, in a per-user folder keyed by the sources
# they are compiled from (riverflow/kernels/_cache.py); an explicit NUMBA_CACHE_DIR is honoured.

.PHONY: help install demo test bench flowmap kernel-signatures pack wheel clean distclean

help:
	@echo "make demo      play the boat demo (no display: renders its scripted run to out/demo/)"
	@echo "make test      run the tests (headless)"
	@echo "make bench     run every benchmarks/*.py"
	@echo "make flowmap   draw the default scene's flow to out/flowmap.png"
	@echo "make kernel-signatures   record the kernels' argument types for the warm-up"
	@echo "make pack      compile the kernels for x86-64-v3 into riverflow/kernels/_pack (shipped in a wheel)"
	@echo "make wheel     build the wheel (with the kernel pack) into dist/"
	@echo "make install   create $(VENV) and install riverflow[test,plot,gis,hosts,cluster] (the others do it too)"
	@echo "make clean     remove caches, outputs and the kernel pack; make distclean also removes $(VENV)"

$(VENV)/.installed: pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --upgrade pip
	$(PY) -m pip install -e '.[test,plot,gis,hosts,cluster]'
	touch $@

install: $(VENV)/.installed

demo: $(VENV)/.installed
	$(PY) -m riverflow demo

# one test worker per core (pytest-xdist); TEST_WORKERS=0 runs them in this process
TEST_WORKERS ?= auto

test: $(VENV)/.installed
	PYGLET_HEADLESS=1 $(PY) -m pytest -q -n $(TEST_WORKERS) --dist loadgroup

bench: $(VENV)/.installed
	@set -e; found=0; for f in benchmarks/*.py; do \
		[ -e "$$f" ] || continue; found=1; \
		echo "== $$f"; $(PY) "$$f"; \
	done; [ $$found = 1 ] || echo "no benchmarks/*.py yet"

flowmap: $(VENV)/.installed
	$(PY) -m riverflow flowmap --out out/flowmap.png

kernel-signatures: $(VENV)/.installed
	$(PY) tools/record_kernel_signatures.py

# the kernels compiled ahead of time for a portable CPU (riverflow/kernels/pack.py); a wheel
# built after it carries them, so `pip install` of the wheel draws its first frame at once
pack: $(VENV)/.installed
	$(PY) tools/build_kernel_pack.py

wheel: pack
	$(PY) -m pip wheel --no-deps --no-build-isolation -w dist .

clean:
	rm -rf .numba_cache .pytest_cache out build dist *.egg-info riverflow/kernels/_pack
	find . -path ./$(VENV) -prune -o -name __pycache__ -type d -exec rm -rf {} +

distclean: clean
	rm -rf $(VENV)
