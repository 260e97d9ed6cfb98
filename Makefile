# Reach — the two commands a newcomer needs:
#   make demo   set up, then plan the paper's four tasks and print Table 2
#   make test   set up, then run every test
# Set-up creates .venv (Python 3.11 + the bpy wheel) once; it needs network access to PyPI.

PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

VERSION := $(shell sed -n 's/^version = "\(.*\)"/\1/p' blender_manifest.toml)
STAGE := build/reach_addon
# Blender's own extension tool, shipped inside the bpy wheel.
BLENDER_EXT = $(shell $(PY) -c 'import bpy, os; print(os.path.join(bpy.utils.system_resource("SCRIPTS"), "addons_core", "bl_pkg", "cli", "blender_ext.py"))' 2>/dev/null)

.PHONY: setup test demo lint dist clean

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

# The extension zip: manifest + package + bundled presets staged into one folder, then
# validated and built by Blender's own tool.
dist: setup
	rm -rf $(STAGE) && mkdir -p $(STAGE) dist
	cp -r reach_addon/. $(STAGE)/
	cp -r presets $(STAGE)/presets
	cp blender_manifest.toml LICENSE $(STAGE)/
	find $(STAGE) -name __pycache__ -prune -exec rm -rf {} +
	$(PY) $(BLENDER_EXT) validate $(STAGE)
	$(PY) $(BLENDER_EXT) build --source-dir $(STAGE) --output-filepath dist/reach_addon-$(VERSION).zip
	@echo "built dist/reach_addon-$(VERSION).zip"

lint: setup
	$(VENV)/bin/ruff check reach_addon tests

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache .hypothesis out dist build
