# rodpack pipeline: every case on every engine that supports it, one analysis, one report.
#   snakemake --cores 2                                   (quick profile, the default)
#   snakemake --cores 2 --configfile workflows/config/paper.yaml
#   snakemake --report results/report.html
# Rules live in workflows/rules/*.smk; the configuration is validated in common.smk.
from snakemake.utils import min_version

min_version("9.0")

if not config:

    configfile: "workflows/config/quick.yaml"


report: "workflows/report/workflow.rst"


include: "workflows/rules/common.smk"
include: "workflows/rules/init.smk"
include: "workflows/rules/engines.smk"
include: "workflows/rules/analysis.smk"
include: "workflows/rules/report.smk"
include: "workflows/rules/bench.smk"


rule all:
    input:
        get_final_output(),
