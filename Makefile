# Two environments, each made once and remade when its requirements change (see README).
PY ?= python3.11
VENV := .venv
VENV_BL := .venv-blender
STAMP := $(VENV)/.installed
STAMP_BL := $(VENV_BL)/.installed
export PIP_DISABLE_PIP_VERSION_CHECK := 1

VERSION := $(shell sed -n 's/^version = "\(.*\)"/\1/p' pyproject.toml | head -n 1)
EXT_ZIP := dist/vfxstereo-$(VERSION)-linux_x64.zip
EXT_SOURCES := $(shell find blender_addon nodes vfxstereo \( -name '*.py' -o -name '*.toml' \) -not -path '*/__pycache__/*') \
	pyproject.toml scripts/build_blender_extension.py

.PHONY: setup demo test test-core test-blender bench lint clean blender-extension

setup: $(STAMP) $(STAMP_BL)

# $(call make-venv,DIR,REQUIREMENTS): create DIR if needed, install REQUIREMENTS and vfxstereo (editable)
define make-venv
	bash scripts/ensure-system-libs.sh
	test -x $(1)/bin/python || $(PY) -m venv $(1)
	$(1)/bin/python -m pip install -q --upgrade pip
	$(1)/bin/python -m pip install -q -r $(2)
	$(1)/bin/python -m pip install -q --no-deps -e .
	touch $(1)/.installed
endef

$(STAMP): requirements/core.txt pyproject.toml
	$(call make-venv,$(VENV),requirements/core.txt)

$(STAMP_BL): requirements/blender.txt pyproject.toml
	$(call make-venv,$(VENV_BL),requirements/blender.txt)

demo: $(STAMP)
	$(VENV)/bin/python samples/demo.py

test: test-core test-blender

# The whole suite on numpy 2 (Blender tests skip themselves without bpy) ...
test-core: $(STAMP)
	$(VENV)/bin/python -m pytest -q -p no:cacheprovider tests

# ... and again on Blender's numpy 1.26 stack, with the Blender tests (they install the extension zip).
test-blender: $(STAMP_BL) $(EXT_ZIP)
	VFXSTEREO_EXTENSION_ZIP=$(abspath $(EXT_ZIP)) $(VENV_BL)/bin/python -m pytest -q -p no:cacheprovider tests

# The installable Blender extension: blender_addon/ + nodes/ + the wheels its manifest lists (README, Blender).
blender-extension: $(EXT_ZIP)

$(EXT_ZIP): $(STAMP_BL) $(EXT_SOURCES)
	$(VENV_BL)/bin/python scripts/build_blender_extension.py --output $@

bench: $(STAMP)
	$(VENV)/bin/python benchmarks/run_all.py

lint: $(STAMP)
	$(VENV)/bin/ruff check vfxstereo tests benchmarks samples blender_addon nodes scripts docs

clean:
	rm -rf $(VENV) $(VENV_BL) out dist
