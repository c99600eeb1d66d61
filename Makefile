# Motion Attention Studio — two entry points on a fresh machine:
#   make run    set up .venv and start the studio with the shipped model
#   make test   set up .venv (and Debian's chromium for browser tests) and run the tests
SHELL := /bin/bash
ROOT := $(dir $(abspath $(lastword $(MAKEFILE_LIST))))
VENV := $(ROOT).venv
PY := $(VENV)/bin/python
PORT ?= 5006

.PHONY: run test setup

setup: $(VENV)/.installed

$(VENV)/.installed: $(ROOT)pyproject.toml
	test -x $(PY) || python3 -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet torch==2.13.0
	$(PY) -m pip install --quiet -e '$(ROOT)[test]'
	touch $@

run: setup
	$(VENV)/bin/moattn serve --port $(PORT)

test: setup
	cd $(ROOT) && $(PY) -m pytest -q
