# One rule per engine; each leaves the common format (docs/formats.md) in its run
# directory: particles.dump, contacts.dump, thermo.dat and run.json (provenance).

RUN = f"{RESULTS}/{{study}}/{{variant}}/seed{{seed}}"
COMMON = ["particles.dump", "contacts.dump", "thermo.dat", "run.json"]


rule run_pysim:
    input:
        case=f"{RUN}/case.yaml",
        data=f"{RUN}/init.data",
    output:
        [f"{RUN}/pysim/{name}" for name in COMMON],
    log:
        f"{RUN}/pysim/log.txt",
    params:
        out=f"{RUN}/pysim",
        timeout=engine_setting("pysim", "timeout", 3600),
    threads: engine_setting("pysim", "threads", 1)
    shell:
        "NUMBA_NUM_THREADS={threads} timeout {params.timeout} {PYTHON} -m pysim run"
        " {input.case} --data {input.data} --out {params.out} --no-progress 2> {log}"


rule run_lammps:
    input:
        case=f"{RUN}/case.yaml",
        data=f"{RUN}/init.data",
    output:
        [f"{RUN}/lammps/{name}" for name in COMMON],
    log:
        f"{RUN}/lammps/log.txt",
    params:
        out=f"{RUN}/lammps",
        timeout=engine_setting("lammps", "timeout", 3600),
    threads: engine_setting("lammps", "ranks", 1)
    shell:
        "{PYTHON} -m workflows.scripts.run_engine --engine lammps --case {input.case}"
        " --data {input.data} --out {params.out} --ranks {threads}"
        " --timeout {params.timeout} 2> {log}"


rule run_liggghts:
    input:
        case=f"{RUN}/case.yaml",
        data=f"{RUN}/init.data",
    output:
        [f"{RUN}/liggghts/{name}" for name in COMMON],
    log:
        f"{RUN}/liggghts/log.txt",
    params:
        out=f"{RUN}/liggghts",
        timeout=engine_setting("liggghts", "timeout", 3600),
    threads: engine_setting("liggghts", "ranks", 1)
    shell:
        "{PYTHON} -m workflows.scripts.run_engine --engine liggghts --case {input.case}"
        " --data {input.data} --out {params.out} --ranks {threads}"
        " --timeout {params.timeout} 2> {log}"
