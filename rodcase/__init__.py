"""The case description every engine reads, and what every run writes beside its output.

* :mod:`rodcase.case` - a case file: schema (``case.schema.yaml``), defaults, checks, the
  derived contact parameters, its hash;
* :mod:`rodcase.record` - the run record ``run.json``;
* :mod:`rodcase.files` - atomic writes (``<name>.part``, then a rename).

The bottom layer: it imports nothing else of rodpack, and pysim, analysis and workflows
may all import it.
"""
