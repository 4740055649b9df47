# pysim against LAMMPS and LIGGGHTS on the same dense packings (workflows/bench.py).
#   snakemake --cores 2 bench      (uses both cores itself: run it alone)


rule bench:
    output:
        csv="results/bench.csv",
        png="results/bench.png",
    log:
        "results/logs/bench.log",
    shell:
        "{sys.executable} -m workflows.bench --out {output.csv} > {log} 2>&1"
