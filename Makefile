# Two environments, each made once and remade when its requirements change (see README).
PY ?= python3.11
VENV := .venv
VENV_BL := .venv-blender
STAMP := $(VENV)/.installed
STAMP_BL := $(VENV_BL)/.installed
export PIP_DISABLE_PIP_VERSION_CHECK := 1

.PHONY: setup demo test test-core test-blender bench lint clean

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

# ... and again on Blender's numpy 1.26 stack, with the Blender tests.
test-blender: $(STAMP_BL)
	$(VENV_BL)/bin/python -m pytest -q -p no:cacheprovider tests

bench: $(STAMP)
	$(VENV)/bin/python benchmarks/run_all.py

lint: $(STAMP)
	$(VENV)/bin/ruff check vfxstereo tests benchmarks samples

clean:
	rm -rf $(VENV) $(VENV_BL) out
