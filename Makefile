# Reach — the two commands a newcomer needs:
#   make demo   set up, then plan the paper's four tasks and print Table 2
#   make test   set up, then run every test
# Set-up creates .venv (Python 3.11 + the bpy wheel) once; it needs network access to PyPI.

PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: setup test demo lint clean

setup: $(STAMP)

$(STAMP): requirements-dev.txt
	@$(PYTHON) -c 'import sys; assert sys.version_info[:2] == (3, 11), "Reach needs Python 3.11 (the bpy 5.0 wheel is built for it), found " + sys.version' 
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements-dev.txt
	touch $@

test: setup
	$(PY) -m pytest

demo: setup
	$(PY) -m reach_addon demo

lint: setup
	$(VENV)/bin/ruff check reach_addon tests

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache .hypothesis out dist build
