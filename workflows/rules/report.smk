# Figures with all engines overlaid, registered for 'snakemake --report'.


def _study_run_dirs(wc):
    return run_dirs(wc.study, wc.variant)


def _p_scale(wc):
    case = CFG["_cases"][
        next(k for k in CFG["_cases"] if k[0] == wc.study and k[1] == wc.variant)
    ]
    return case["contact"]["k_n"] / case["particles"]["diameter"]["mean"]


def _friction(wc):
    case = CFG["_cases"][
        next(k for k in CFG["_cases"] if k[0] == wc.study and k[1] == wc.variant)
    ]
    return case["contact"]["friction"]


def _study_p_scale(study):
    # k_n / D of the study's first case: variants of one study share the pressure unit
    case = CFG["_cases"][next(k for k in CFG["_cases"] if k[0] == study)]
    return case["contact"]["k_n"] / case["particles"]["diameter"]["mean"]


rule plot_study:
    input:
        lambda wc: [
            f"{d}/{name}"
            for d in _study_run_dirs(wc)
            for name in ("observables.csv", "curves.csv", "run.json")
        ],
    output:
        pressure=report(
            f"{RESULTS}/{{study}}/figures/{{variant}}.pressure.png",
            caption="../report/pressure.rst",
            category="{study}",
            subcategory="{variant}",
        ),
        contacts=report(
            f"{RESULTS}/{{study}}/figures/{{variant}}.contacts.png",
            caption="../report/contacts.rst",
            category="{study}",
            subcategory="{variant}",
        ),
        phi_j=report(
            f"{RESULTS}/{{study}}/figures/{{variant}}.phi_j.png",
            caption="../report/phi_j.rst",
            category="{study}",
            subcategory="{variant}",
        ),
    log:
        f"{RESULTS}/{{study}}/figures/{{variant}}.log",
    params:
        dirs=lambda wc: " ".join(_study_run_dirs(wc)),
        p_scale=_p_scale,
        window=lambda wc: " ".join(map(str, _window(wc))),
        friction=_friction,
        c_min=_c_min,
    shell:
        "{PYTHON} -m workflows.scripts.plot_study --pressure {output.pressure}"
        " --contacts {output.contacts} --phi-j {output.phi_j} --p-scale {params.p_scale}"
        " --window {params.window} --friction {params.friction} {params.c_min}"
        " {params.dirs} 2> {log}"


#: physical parameters a study's trends are drawn against, in order of preference: the
#: time step or output intervals may vary beside them (small particles need a shorter
#: step, slow runs write less often) and are never the axis then
TREND_PARAMETERS = ("alpha", "sigma", "kappa", "bond_number")


def _trend_parameter(study):
    params = sorted(set(varying_parameters(CFG, study)) - {"thermo_every", "dump_every"})
    preferred = [p for p in TREND_PARAMETERS if p in params]
    return preferred[0] if preferred else (params[0] if params else None)


def _trend_series(study):
    # a second physical parameter is drawn as one line per value: deposits vary the Bond
    # number beside the aspect ratio; sphere packings the compression rate beside sigma,
    # on a full grid (a rate set for a few aspect ratios only, as for long rods, is a
    # numerical setting, not a series)
    params = varying_parameters(CFG, study)
    axis = _trend_parameter(study)
    if axis == "alpha" and "bond_number" in params:
        return "--series bond_number"
    for other in TREND_PARAMETERS:
        if axis in TREND_PARAMETERS and other != axis and other in params:
            pairs = {(params[axis][v], params[other][v]) for v in params[axis]}
            if len(pairs) == len(set(params[axis].values())) * len(set(params[other].values())):
                return f"--series {other}"
    return ""


rule plot_trends:
    input:
        f"{RESULTS}/summary.csv",
    output:
        report(
            f"{RESULTS}/{{study}}/figures/trends.png",
            caption="../report/trends.rst",
            category="{study}",
        ),
    log:
        f"{RESULTS}/{{study}}/figures/trends.log",
    params:
        parameter=lambda wc: _trend_parameter(wc.study),
        dimension=lambda wc: CFG["studies"][wc.study]["case"]["particles"].get("dimension", 3),
        series=lambda wc: _trend_series(wc.study),
        protocol=lambda wc: CFG["studies"][wc.study]["case"]["protocol"]["name"],
    shell:
        "{PYTHON} -m workflows.scripts.plot_trends --summary {input} --study {wildcards.study}"
        " --parameter {params.parameter} --dimension {params.dimension} {params.series}"
        " --protocol {params.protocol} --out {output} 2> {log}"


rule plot_angles:
    input:
        lambda wc: [
            f"{d}/{name}" for d in run_dirs(wc.study) for name in ("observables.csv", "run.json")
        ],
    output:
        report(
            f"{RESULTS}/{{study}}/figures/contact_angles.png",
            caption="../report/contact_angles.rst",
            category="{study}",
        ),
    log:
        f"{RESULTS}/{{study}}/figures/contact_angles.log",
    params:
        runs=lambda wc: " ".join(run_dirs(wc.study)),
    shell:
        "{PYTHON} -m workflows.scripts.plot_angles --runs {params.runs} --out {output} 2> {log}"


def modes_run_dirs(study):
    """pysim run directories of the study's variants that get vibrational modes
    (``analysis.modes_variants``; every variant without it)."""
    chosen = CFG["studies"][study].get("analysis", {}).get("modes_variants") or [None]
    return [d for v in chosen for d in run_dirs(study, v) if d.endswith("/pysim")]


def modes_energies(study):
    """``--energies ...`` of the study's ``analysis.modes_energies``, or nothing (the
    script's default)."""
    energies = CFG["studies"][study].get("analysis", {}).get("modes_energies")
    return "" if energies is None else "--energies " + " ".join(f"{u:g}" for u in energies)


rule plot_modes:
    input:
        lambda wc: [f"{d}/run.json" for d in modes_run_dirs(wc.study)],
    output:
        figure=report(
            f"{RESULTS}/{{study}}/figures/modes.png",
            caption="../report/modes.rst",
            category="{study}",
        ),
        table=f"{RESULTS}/{{study}}/modes.csv",
    log:
        f"{RESULTS}/{{study}}/figures/modes.log",
    params:
        runs=lambda wc: " ".join(modes_run_dirs(wc.study)),
        energies=lambda wc: modes_energies(wc.study),
    shell:
        "{PYTHON} -m workflows.scripts.modes --runs {params.runs} --out {output.figure}"
        " --table {output.table} {params.energies} 2> {log}"


rule plot_order:
    input:
        lambda wc: [
            f"{d}/{name}" for d in run_dirs(wc.study) for name in ("curves.csv", "run.json")
        ],
    output:
        figure=report(
            f"{RESULTS}/{{study}}/figures/order_scaling.png",
            caption="../report/order_scaling.rst",
            category="{study}",
        ),
        table=f"{RESULTS}/{{study}}/order_scaling.csv",
    log:
        f"{RESULTS}/{{study}}/figures/order_scaling.log",
    params:
        runs=lambda wc: " ".join(run_dirs(wc.study)),
    shell:
        "{PYTHON} -m workflows.scripts.plot_order --runs {params.runs} --out {output.figure}"
        " --table {output.table} 2> {log}"


rule plot_pressures:
    input:
        lambda wc: [
            f"{d}/{name}" for d in run_dirs(wc.study) for name in ("observables.csv", "run.json")
        ],
    output:
        report(
            f"{RESULTS}/{{study}}/figures/pressure_variants.png",
            caption="../report/pressure_variants.rst",
            category="{study}",
        ),
    log:
        f"{RESULTS}/{{study}}/figures/pressure_variants.log",
    params:
        runs=lambda wc: " ".join(run_dirs(wc.study)),
        parameter=lambda wc: _trend_parameter(wc.study),
        p_scale=lambda wc: _study_p_scale(wc.study),
    shell:
        "{PYTHON} -m workflows.scripts.plot_pressures --runs {params.runs}"
        " --parameter {params.parameter} --p-scale {params.p_scale} --out {output} 2> {log}"


rule body_check:
    output:
        table=report(
            f"{RESULTS}/body_check/body_check.csv",
            caption="../report/body_check.rst",
            category="LAMMPS body rods",
        ),
        figure=report(
            f"{RESULTS}/body_check/body_check.png",
            caption="../report/body_check.rst",
            category="LAMMPS body rods",
        ),
    log:
        f"{RESULTS}/body_check/body_check.log",
    params:
        work=f"{RESULTS}/body_check/work",
    shell:
        "{PYTHON} -m workflows.scripts.body_check --alpha 2 --work {params.work}"
        " --table {output.table} --figure {output.figure} 2> {log}"


def _restitution_case(wc=None):
    case = restitution_case()
    if case is None:
        raise ValueError("the restitution check needs a tapping study that runs rods on the "
                         "'lammps' engine (glued spheres); this config has none")
    return case


rule restitution_check:
    input:
        case=_restitution_case,
    output:
        table=report(
            f"{RESULTS}/restitution_check/restitution_check.csv",
            caption="../report/restitution_check.rst",
            category="LAMMPS glued rods",
        ),
        figure=report(
            f"{RESULTS}/restitution_check/restitution_check.png",
            caption="../report/restitution_check.rst",
            category="LAMMPS glued rods",
        ),
    log:
        f"{RESULTS}/restitution_check/restitution_check.log",
    params:
        work=f"{RESULTS}/restitution_check/work",
        label=lambda wc: "/".join(_restitution_case().split("/")[-4:-2]),  # study/variant
    shell:
        "{PYTHON} -m workflows.scripts.restitution_check --case {input.case} --label {params.label}"
        " --work {params.work} --table {output.table} --figure {output.figure} 2> {log}"


rule plot_deposit:
    input:
        lambda wc: [
            f"{d}/{name}" for d in run_dirs(wc.study) for name in ("curves.csv", "run.json")
        ],
    output:
        report(
            f"{RESULTS}/{{study}}/figures/deposit.png",
            caption="../report/deposit.rst",
            category="{study}",
        ),
    log:
        f"{RESULTS}/{{study}}/figures/deposit.log",
    params:
        dirs=lambda wc: " ".join(run_dirs(wc.study)),
    shell:
        "{PYTHON} -m workflows.scripts.plot_deposit --out {output} {params.dirs} 2> {log}"


rule plot_janssen:
    input:
        lambda wc: [
            f"{d}/{name}"
            for d in run_dirs(wc.study)
            for name in ("curves.csv", "observables.csv", "run.json")
        ],
    output:
        report(
            f"{RESULTS}/{{study}}/figures/janssen.png",
            caption="../report/janssen.rst",
            category="Against the papers",
        ),
    log:
        f"{RESULTS}/{{study}}/figures/janssen.log",
    params:
        dirs=lambda wc: " ".join(run_dirs(wc.study)),
    shell:
        "{PYTHON} -m workflows.scripts.plot_janssen --out {output} {params.dirs} 2> {log}"


rule plot_tapping:
    input:
        lambda wc: [
            f"{d}/{name}" for d in run_dirs(wc.study) for name in ("curves.csv", "run.json")
        ],
    output:
        report(
            f"{RESULTS}/{{study}}/figures/tapping.png",
            caption="../report/tapping.rst",
            category="{study}",
        ),
    log:
        f"{RESULTS}/{{study}}/figures/tapping.log",
    params:
        dirs=lambda wc: " ".join(run_dirs(wc.study)),
    shell:
        "{PYTHON} -m workflows.scripts.plot_tapping --curves-out {output} {params.dirs} 2> {log}"


rule plot_tapping_sets:
    input:
        lambda wc: [
            f"{d}/{name}" for d in run_dirs(wc.study) for name in ("observables.csv", "run.json")
        ],
    output:
        figure=report(
            f"{RESULTS}/{{study}}/figures/sets.png",
            caption="../report/tapping_sets.rst",
            category="{study}",
        ),
        table=report(
            f"{RESULTS}/{{study}}/sets.csv",
            caption="../report/tapping_sets.rst",
            category="{study}",
        ),
    log:
        f"{RESULTS}/{{study}}/figures/sets.log",
    params:
        dirs=lambda wc: " ".join(run_dirs(wc.study)),
    shell:
        "{PYTHON} -m workflows.scripts.plot_tapping --sets-out {output.figure}"
        " --sets-table {output.table} {params.dirs} 2> {log}"


rule plot_tapping_snapshots:
    input:
        lambda wc: [
            f"{d}/{name}"
            for d in run_dirs(wc.study, wc.variant)
            for name in ("curves.csv", "run.json")
        ],
    output:
        report(
            f"{RESULTS}/{{study}}/figures/{{variant}}.snapshots.png",
            caption="../report/snapshots.rst",
            category="{study}",
            subcategory="{variant}",
        ),
    log:
        f"{RESULTS}/{{study}}/figures/{{variant}}.snapshots.log",
    params:
        dirs=lambda wc: " ".join(run_dirs(wc.study, wc.variant)),
    shell:
        "{PYTHON} -m workflows.scripts.plot_tapping --snapshots-out {output}"
        " {params.dirs} --taps 0 300 900 -1 2> {log}"


rule plot_packing:
    input:
        lambda wc: [f"{d}/run.json" for d in run_dirs(wc.study, wc.variant)],
    output:
        report(
            f"{RESULTS}/{{study}}/figures/{{variant}}.packing.png",
            caption="../report/packing.rst",
            category="{study}",
            subcategory="{variant}",
        ),
    log:
        f"{RESULTS}/{{study}}/figures/{{variant}}.packing.log",
    params:
        dirs=lambda wc: " ".join(run_dirs(wc.study, wc.variant)),
    shell:
        "{PYTHON} -m workflows.scripts.plot_snapshots --out {output} {params.dirs} 2> {log}"


rule landing:
    input:
        summary=f"{RESULTS}/summary.csv",
        comparison=f"{RESULTS}/comparison.csv",
        failures=f"{RESULTS}/failures.csv",
        vs_paper=f"{RESULTS}/vs_paper.csv",
    output:
        page=f"{RESULTS}/landing.html",
        figure=report(
            f"{RESULTS}/figures/engine_differences.png",
            caption="../report/engine_differences.rst",
            category="Tables",
        ),
    log:
        f"{RESULTS}/landing.log",
    shell:
        "{PYTHON} -m workflows.scripts.landing --results {RESULTS} --html {output.page}"
        " --figure {output.figure} 2> {log}"


rule growth_rates:
    input:
        lambda wc: [
            f"{d}/{name}"
            for d in growth_groups(wc.study)[wc.alpha]
            for name in ("observables.csv", "curves.csv", "run.json")
        ],
    output:
        figure=report(
            f"{RESULTS}/{{study}}/figures/growth_alpha{{alpha}}.png",
            caption="../report/growth_rates.rst",
            category="{study}",
        ),
        table=f"{RESULTS}/{{study}}/growth_alpha{{alpha}}.csv",
    wildcard_constraints:
        alpha=r"[0-9.]+",
    log:
        f"{RESULTS}/{{study}}/figures/growth_alpha{{alpha}}.log",
    params:
        dirs=lambda wc: " ".join(growth_groups(wc.study)[wc.alpha]),
    shell:
        "{PYTHON} -m workflows.scripts.growth_rates --figure {output.figure}"
        " --table {output.table} {params.dirs} 2> {log}"


rule closest_jamming:
    input:
        lambda wc: [
            f"{RESULTS}/{r.run_dir}/{name}"
            for r in RUNS if r.study == wc.study
            for name in ("observables.csv", "run.json")
        ],
    output:
        figure=report(
            f"{RESULTS}/{{study}}/figures/closest_jamming.png",
            caption="../report/closest_jamming.rst",
            category="{study}",
        ),
        table=f"{RESULTS}/{{study}}/closest_jamming.csv",
    log:
        f"{RESULTS}/{{study}}/figures/closest_jamming.log",
    params:
        dirs=lambda wc: " ".join(f"{RESULTS}/{r.run_dir}" for r in RUNS if r.study == wc.study),
    shell:
        "{PYTHON} -m workflows.scripts.closest_jamming --figure {output.figure}"
        " --table {output.table} {params.dirs} 2> {log}"


rule caging_numbers:
    output:
        table=f"{RESULTS}/{{study}}/caging.csv",
        figure=report(
            f"{RESULTS}/{{study}}/figures/caging.png",
            caption="../report/caging.rst",
            category="{study}",
        ),
    log:
        f"{RESULTS}/{{study}}/figures/caging.log",
    params:
        args=lambda wc: caging_args(wc.study),
    shell:
        "{PYTHON} -m workflows.scripts.caging_numbers --table {output.table}"
        " --figure {output.figure} {params.args} 2> {log}"
