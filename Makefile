# Reach — the two commands a newcomer needs:
#   make demo   set up, then perform the paper's four tasks in Blender: out/demo.blend,
#               stills, an MP4, out/report.json and Table 2 beside the paper's
#   make test   set up, then run every test: the whole suite on bpy 5.0.1, the add-on and
#               bake tests again on bpy 4.2 LTS and 4.5, and a real Blender binary (Debian's
#               3.4.1) headless and in a GUI under Xvfb
# Also: make bench (bench/results.md), make dist (the extension zip), make lint,
# make docs (the README's pictures in docs/, from the GUI test and the demo).
# make fuzz: FUZZ_N generated scenes (default 10000) baked and checked, counts in bench/fuzz.json.
# Set-up creates .venv (Python 3.11 + the bpy wheel) once; it needs network access to PyPI,
# and apt-get (root or sudo) for the system packages of the binary tests.

PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

VERSION := $(shell sed -n 's/^version = "\(.*\)"/\1/p' blender_manifest.toml)
STAGE := build/reach_addon
# Blender's own extension tool, shipped inside the bpy wheel.
BLENDER_EXT = $(shell $(PY) -c 'import bpy, os; print(os.path.join(bpy.utils.system_resource("SCRIPTS"), "addons_core", "bl_pkg", "cli", "blender_ext.py"))' 2>/dev/null)

# The version matrix: one venv per older Blender, created on first use. The core and
# command-line tests run once, on 5.0.1; these run on every version.
MATRIX := 4.2 4.5
BPY_4.2 := 4.2.23
BPY_4.5 := 4.5.15
MATRIX_TESTS := tests/blender/test_extension.py tests/blender/test_bake.py \
	tests/blender/test_bad_input.py tests/blender/test_presets.py \
	tests/blender/test_obstacle_types.py tests/blender/test_quaternions.py

.PHONY: setup test demo bench lint dist clean system-deps matrix fuzz docs

setup: $(STAMP)

$(STAMP): requirements-dev.txt
	@$(PYTHON) -c 'import sys; assert sys.version_info[:2] == (3, 11), "Reach needs Python 3.11 (the bpy 5.0 wheel is built for it), found " + sys.version' 
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements-dev.txt
	touch $@

.venv-%/.installed:
	test -x .venv-$*/bin/python || $(PYTHON) -m venv .venv-$*
	.venv-$*/bin/python -m pip install --quiet "bpy==$(BPY_$*)" "numpy<2" pytest hypothesis
	touch $@

system-deps:
	sh tools/system-deps.sh

test: setup system-deps $(MATRIX:%=.venv-%/.installed)
	$(PY) tools/import_cycles.py
	$(PY) -m pytest
	@for v in $(MATRIX); do \
		echo "== the add-on and bake tests on bpy $$v"; \
		.venv-$$v/bin/python -m pytest -p no:cacheprovider $(MATRIX_TESTS) || exit 1; \
	done

matrix: setup $(MATRIX:%=.venv-%/.installed)
	@for v in $(MATRIX); do \
		.venv-$$v/bin/python -m pytest -p no:cacheprovider $(MATRIX_TESTS) || exit 1; \
	done

demo: setup
	$(PY) -m reach_addon demo --output out

# The README's pictures: the GUI test's screenshot (Blender 3.4.1 under Xvfb) and the
# demo's stills, copied into docs/ by tools/docs.py.
docs: setup system-deps
	$(PY) -m pytest -p no:cacheprovider tests/binary/test_gui_panel.py
	$(PY) -m reach_addon demo --output out
	$(PY) tools/docs.py

bench: setup
	$(PY) -m pip install --quiet -r requirements-bench.txt
	$(PY) bench/run.py
	$(PY) bench/readme.py

# The fuzz campaign: seeded scenes baked as a user bakes them, each outcome checked
# independently; one worker process per core. A fixed-seed subset runs in make test.
FUZZ_N ?= 10000
FUZZ_JOBS ?= $(shell nproc 2>/dev/null || echo 2)
# kept results: a campaign stopped part way carries on when run again on the same code
FUZZ_RUNS ?= out/fuzz-runs

fuzz: setup
	$(PY) bench/fuzz.py --count $(FUZZ_N) --jobs $(FUZZ_JOBS) --resume $(FUZZ_RUNS) --out bench/fuzz.json
	$(PY) bench/readme.py

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
	$(VENV)/bin/ruff check reach_addon tests verification bench

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache .hypothesis out dist build
