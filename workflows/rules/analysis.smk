# The same analysis for every engine: per-run observables, then the joined tables.


def _window(wc):
    return CFG["studies"][wc.study].get("analysis", {}).get("jamming_window", [1e-3, 1e-2])


def _c_min(wc):
    """``--c-min N`` when the study's analysis sets the rattler rule, else nothing."""
    c_min = CFG["studies"][wc.study].get("analysis", {}).get("c_min")
    return "" if c_min is None else f"--c-min {int(c_min)}"


def _parameters(wc):
    return json.dumps({k: v[wc.variant] for k, v in varying_parameters(CFG, wc.study).items()})


rule analyse_run:
    input:
        case=f"{RUN}/case.yaml",
        record=f"{RUN}/{{engine}}/run.json",
    output:
        observables=f"{RUN}/{{engine}}/observables.csv",
        curves=f"{RUN}/{{engine}}/curves.csv",
    log:
        f"{RUN}/{{engine}}/analysis.log",
    params:
        run=f"{RUN}/{{engine}}",
        window=lambda wc: " ".join(map(str, _window(wc))),
        c_min=_c_min,
        parameters=_parameters,
    wildcard_constraints:
        engine="pysim|lammps|lammps-body|liggghts",
    # a finished run is analysed before the next engine run starts: a long profile shows
    # its results as they come (and a run's analysis error surfaces hours earlier)
    priority: 10
    shell:
        "{PYTHON} -m workflows.scripts.analyse_run --case {input.case} --run {params.run}"
        " --study {wildcards.study} --variant {wildcards.variant} --seed {wildcards.seed}"
        " --engine {wildcards.engine} --window {params.window} {params.c_min}"
        " --parameters '{params.parameters}'"
        " --observables {output.observables} --curves {output.curves} 2> {log}"


rule summary:
    input:
        observables=[f"{d}/observables.csv" for d in run_dirs()],
        records=[f"{d}/run.json" for d in run_dirs()],
    output:
        summary=report(
            f"{RESULTS}/summary.csv",
            caption="../report/summary.rst",
            category="Tables",
        ),
        comparison=report(
            f"{RESULTS}/comparison.csv",
            caption="../report/comparison.rst",
            category="Tables",
        ),
        failures=report(
            f"{RESULTS}/failures.csv",
            caption="../report/failures.rst",
            category="Tables",
        ),
    log:
        f"{RESULTS}/summary.log",
    shell:
        "{PYTHON} -m workflows.scripts.summarize --summary {output.summary}"
        " --comparison {output.comparison} --failures {output.failures}"
        " --records {input.records} --observables {input.observables} 2> {log}"


rule vs_paper:
    input:
        summary=f"{RESULTS}/summary.csv",
        modes=lambda wc: [f"{RESULTS}/{s}/modes.csv" for s in modes_studies()],
        growth=lambda wc: [f"{RESULTS}/{s}/growth_alpha{a}.csv"
                           for s in sorted({s for s, _ in study_variants()})
                           for a in growth_groups(s)],
        closest_jamming=lambda wc: [f"{RESULTS}/{s}/closest_jamming.csv" for s in hard_studies()],
        caging=lambda wc: [f"{RESULTS}/{s}/caging.csv" for s in caging_studies()],
        references=sorted(glob.glob(os.path.join(REFERENCES, "*.csv"))),
    output:
        table=report(
            f"{RESULTS}/vs_paper.csv",
            caption="../report/vs_paper.rst",
            category="Against the papers",
        ),
        figure=report(
            f"{RESULTS}/figures/vs_paper.png",
            caption="../report/vs_paper_figure.rst",
            category="Against the papers",
        ),
    log:
        f"{RESULTS}/vs_paper.log",
    shell:
        "{PYTHON} -m workflows.scripts.vs_paper --references {REFERENCES}"
        " --results {RESULTS} --out {output.table} --figure {output.figure} 2> {log}"


def _echo_analysis_warnings():
    """Repeat the 'warning:' lines of every analysis log (NaN observables, packings that
    the rattler rule empties: workflows/scripts/analyse_run.py) where the user sees them."""
    for d in run_dirs():
        log = Path(d) / "analysis.log"
        if log.is_file():
            for line in log.read_text(errors="replace").splitlines():
                if line.startswith("warning:"):
                    sys.stderr.write(f"rodpack: {line}\n")


onsuccess:
    _echo_analysis_warnings()


onerror:
    _echo_analysis_warnings()
