"""rodpack's workflow layer: case/configuration handling, engine drivers, the
Snakemake rules (``rules/``), configurations (``config/``) and schemas (``schemas/``)."""
