# The two commands a newcomer needs:
#   make book   set up .venv, execute every chapter, render the site to _build/html
#   make test   set up .venv, run the unit tests and every chapter in the smoke profile
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-$(shell sha1sum pyproject.toml | cut -c1-12)
PROFILE ?= laptop
JOBS    ?= 2

.PHONY: book test lint clean setup

setup: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/pip install -e '.[dev]'
	rm -f $(VENV)/.installed-*; touch $@

# Train every model first (JOBS worker processes, resumable), execute the chapters JOBS at a time (a chapter whose
# kernel stalls is restarted), then render the executed notebooks without executing them again.
book: $(STAMP)
	$(BIN)/python tools/vendor_web_assets.py   # MathJax + widget JS for an offline site (npm ci, once)
	MOTIONLAB_PROFILE=$(PROFILE) $(BIN)/motionlab train book --jobs $(JOBS)
	MOTIONLAB_PROFILE=$(PROFILE) $(BIN)/motionlab book execute --jobs $(JOBS)
	rm -rf _build/html _build/.doctrees _build/jupyter_execute
	cd _build/site-src && $(CURDIR)/$(BIN)/jupyter-book build . --toc book/_toc.yml --path-output $(CURDIR) -W -n --keep-going

test: $(STAMP)
	MOTIONLAB_PROFILE=smoke $(BIN)/python -m pytest --nbval-lax --nbval-current-env

# ruff lints and checks the formatting of the library, the tests, the tools and the chapters' code cells (.ipynb)
LINTED := src tests benchmarks tools experiments notebooks
lint: $(STAMP)
	$(BIN)/ruff check $(LINTED)
	$(BIN)/ruff format --check $(LINTED)

clean:
	rm -rf _build
