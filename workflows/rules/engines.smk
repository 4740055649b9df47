# One rule runs any engine (workflows/runner.py). It always leaves run.json: status ok
# with the common format beside it (docs/formats.md), or status failed with the engine's
# error line and log, so one failed run never stops the others and the report lists it.

RUN = f"{RESULTS}/{{study}}/{{variant}}/seed{{seed}}"


def _threads(wc):
    if wc.engine == "pysim":
        return engine_setting("pysim", "threads", 1)
    return engine_setting(wc.engine, "ranks", 1)


def _timeout_s(wc):
    return int(math.ceil(engine_setting(wc.engine, "timeout", 3600)))


rule run_engine:
    input:
        case=f"{RUN}/case.yaml",
        data=f"{RUN}/init.data",
    output:
        f"{RUN}/{{engine}}/run.json",
    log:
        f"{RUN}/{{engine}}/log.txt",
    params:
        out=f"{RUN}/{{engine}}",
    wildcard_constraints:
        engine="pysim|lammps|lammps-body|liggghts",
    threads: _threads
    # the budget is a resource, not a param: raising it must not rerun finished runs, and
    # a cluster executor books the same wall time (runtime, minutes) for the job
    resources:
        timeout_s=_timeout_s,
        runtime=lambda wc: _timeout_s(wc) // 60 + 10,
    shell:
        "{PYTHON} -m workflows.scripts.run_engine --engine {wildcards.engine}"
        " --case {input.case} --data {input.data} --out {params.out}"
        " --ranks {threads} --threads {threads} --timeout {resources.timeout_s} 2> {log}"
