# Setup and entry points. Both targets create .venv when missing.
PY      ?= python3
VENV    := .venv
VPY     := $(VENV)/bin/python
STAMP   := $(VENV)/.installed
SHARED  ?= ../shared/data/problems
PYTEST_ARGS ?= -n 2

.PHONY: demo test bench validate clean clean-cache

$(VPY):
	$(PY) -m venv $(VENV)
	$(VPY) -m pip install --quiet --upgrade pip

$(STAMP): $(VPY) pyproject.toml
	$(VPY) -m pip install --quiet -e ".[test]"
	touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/socp-cd demo --data $(SHARED)

test: $(STAMP)
	$(VPY) -m pytest $(PYTEST_ARGS) tests

bench: $(STAMP)
	$(VENV)/bin/socp-cd bench --preset all --data $(SHARED) --readme README.md

validate: $(STAMP)
	$(VENV)/bin/socp-cd validate

clean: clean-cache
	rm -rf $(VENV) build *.egg-info .pytest_cache

# numba's cache (cache=True) is keyed on each function's own file: a cached caller keeps
# the old code of a kernel it calls from another file until this is run
clean-cache:
	find socp_cd -name '*.nbi' -delete -o -name '*.nbc' -delete
