PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
# every extra (tests, docs, benchmarks: what CI installs)
STAMP := $(VENV)/.installed
# what the demo needs: geogait and its compiled one-sample path (the extra "fast")
DEMO_STAMP := $(VENV)/.installed-demo

.PHONY: install demo test test-fast docs bench bench-robots lint clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/pip install --quiet -e ".[dev]"
	touch $(STAMP)

$(DEMO_STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/pip install --quiet -e ".[fast]"
	touch $(DEMO_STAMP)

install: $(STAMP)

demo: $(DEMO_STAMP)
	$(BIN)/geogait optimize --links 3 --overwrite --out out/demo

test: $(STAMP)
	$(BIN)/python -m pytest -n 2

test-fast: $(STAMP)
	$(BIN)/python -m pytest -n 2 -m "not slow"

# warnings are errors (-W), each gallery example runs; then no internal link of the built site may be dead and no
# markup may show as text (docs/check_site.py)
docs: $(STAMP)
	rm -rf site
	MPLBACKEND=Agg $(BIN)/sphinx-build -W --keep-going -b html docs site
	$(BIN)/python docs/check_site.py site

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py

bench-robots: $(STAMP)
	$(BIN)/python benchmarks/robots.py --out docs/results/robots

lint: $(STAMP)
	$(BIN)/ruff check .

clean:
	rm -rf $(VENV) out benchmarks/results site docs/api/geogait*.rst docs/api/generated docs/auto_examples
