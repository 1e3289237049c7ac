# Two commands do all set-up on a fresh machine (see README):
#   make demo   creates .venv, installs, runs `nniquad report` on the paper's vehicle into out/
#   make test   installs if needed, runs the whole test suite (notebooks included)
# make mutation [MODULE=metrics] [SURVIVORS=1]: mutation score of the verdict modules (tests/mutation/, mutmut);
#   SURVIVORS=1 runs again only the last full run's survivors, against the current tests
# make planted: the planted bugs, each in a staged copy, must fail the tests meant to catch them
# make notebooks: the notebooks executed and rendered to HTML into notebooks/_build/html ([NNIQUAD_VEHICLE=FILE]
#   studies another vehicle; NNIQUAD_NOTEBOOK_SIZE=smoke runs the coarse grids of the tests)
# make docs: the docs site (docs/*.md and the API reference from the docstrings) into docs/_build/html
PYTHON ?= python3
VENV   ?= .venv
PY      = $(VENV)/bin/python
STAMP   = $(VENV)/.installed-stamp
JOBS   ?= 2

.PHONY: install demo test bench bench-quick notebooks mutation planted docs clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/nniquad report --out out

test: $(STAMP)
	MPLBACKEND=Agg $(PY) -m pytest -n $(JOBS) --dist loadgroup -q

bench: $(STAMP)
	MPLBACKEND=Agg $(PY) benchmarks/run.py --json benchmarks/results/latest.json

mutation: $(STAMP)
	MPLBACKEND=Agg $(PY) tests/mutation/run.py --jobs $(JOBS) $(if $(MODULE),--module $(MODULE)) $(if $(SURVIVORS),--survivors)

planted: $(STAMP)
	MPLBACKEND=Agg $(PY) tests/mutation/planted.py --jobs $(JOBS)

bench-quick: $(STAMP)
	MPLBACKEND=Agg $(PY) benchmarks/run.py --quick --json benchmarks/results/quick.json

docs: $(STAMP)
	MPLBACKEND=Agg $(PY) -m sphinx -W --keep-going -b html -q docs docs/_build/html
	@echo "docs: docs/_build/html/index.html"

notebooks: $(STAMP)
	$(VENV)/bin/jupytext --to ipynb notebooks/*.py
	MPLBACKEND=Agg $(VENV)/bin/jupyter nbconvert --to html --execute --ExecutePreprocessor.timeout=3600 \
		--output-dir notebooks/_build/html notebooks/*.ipynb
	@echo "notebooks: notebooks/_build/html/*.html (NNIQUAD_VEHICLE=FILE studies another vehicle)"

clean:
	rm -rf $(VENV) out build *.egg-info benchmarks/results docs/_build docs/api
