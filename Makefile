# Motion Attention Studio — two entry points on a fresh machine:
#   make run    set up .venv and start the studio with the shipped model
#   make test   set up .venv (and Debian's chromium for browser tests) and run the tests
SHELL := /bin/bash
ROOT := $(dir $(abspath $(lastword $(MAKEFILE_LIST))))
VENV := $(ROOT).venv
PY := $(VENV)/bin/python
PORT ?= 5006

.PHONY: run test setup chromium

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

test: setup chromium
	cd $(ROOT) && $(PY) -m pytest -q
