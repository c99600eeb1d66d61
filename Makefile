# Motion Attention Studio — two entry points on a fresh machine:
#   make run    set up .venv and start the studio with the shipped model
#   make test   set up .venv (and Debian's chromium for browser tests, npm's glTF validator) and run the tests
SHELL := /bin/bash
ROOT := $(dir $(abspath $(lastword $(MAKEFILE_LIST))))
VENV := $(ROOT).venv
PY := $(VENV)/bin/python
PORT ?= 5006

.PHONY: run test guide setup chromium gltf-validator

setup: $(VENV)/.installed

$(VENV)/.installed: $(ROOT)pyproject.toml
	test -x $(PY) || python3 -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet torch==2.13.0
	$(PY) -m pip install --quiet -e '$(ROOT)[test]'
	touch $@

run: setup
	$(VENV)/bin/moattn serve --port $(PORT)

# Debian's chromium drives the browser tests (Playwright is only the driver; no browser is downloaded)
chromium:
	command -v chromium >/dev/null || { SUDO=$$([ "$$(id -u)" = 0 ] || echo sudo); \
	  $$SUDO apt-get update && $$SUDO apt-get install -y chromium; }

# Khronos' glTF validator checks the GLB export in the tests (npm's gltf-validator, a test tool only: the app needs no node)
GLTF_VALIDATOR := $(ROOT).tools/node/node_modules/gltf-validator/package.json
gltf-validator: $(GLTF_VALIDATOR)

$(GLTF_VALIDATOR):
	command -v npm >/dev/null || { SUDO=$$([ "$$(id -u)" = 0 ] || echo sudo); \
	  $$SUDO apt-get update && $$SUDO apt-get install -y nodejs npm; }
	npm install --silent --no-audit --no-fund --prefix $(ROOT).tools/node gltf-validator@2.0.0-dev.3.10

test: setup chromium gltf-validator
	cd $(ROOT) && $(PY) -m pytest -q

# rewrite app/guide/*.png (the user guide's pictures) from the studio itself
guide: setup chromium
	cd $(ROOT) && MOATTN_WRITE_GUIDE=1 $(PY) -m pytest -q tests/browser/test_guide_browser.py
