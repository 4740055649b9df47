# The merged case file and the shared initial configuration of a (study, variant, seed).


rule init_case:
    output:
        case=f"{RESULTS}/{{study}}/{{variant}}/seed{{seed}}/case.yaml",
        data=f"{RESULTS}/{{study}}/{{variant}}/seed{{seed}}/init.data",
    log:
        f"{RESULTS}/{{study}}/{{variant}}/seed{{seed}}/init.log",
    params:
        case=lambda wc: json.dumps(case_of(wc)),
    shell:
        "{PYTHON} -m workflows.scripts.init_case --case-json '{params.case}'"
        " --case-out {output.case} --data-out {output.data} 2> {log}"
