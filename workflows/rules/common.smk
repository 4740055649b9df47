# Configuration validation, the run table and the final targets.
import glob
import math
from pathlib import Path
import json
import os
import sys

from rodcase.case import HARD_SPHERE_PROTOCOLS, ConfigError, read_yaml
from workflows.studies import runs as expand_runs, validate_config, varying_parameters

PYTHON = sys.executable
_CONFIG_SOURCE = ", ".join(map(str, workflow.configfiles)) or "config"

try:
    for _path in workflow.configfiles:
        read_yaml(_path)  # Snakemake's own loader keeps the last of a key given twice
    CFG = validate_config(config, source=_CONFIG_SOURCE)
except ConfigError as exc:
    sys.stderr.write(f"error: {exc}\n")
    sys.exit(2)

RESULTS = CFG["results"]
# the report's first page (rule landing), read when the report is built
if os.path.exists(f"{RESULTS}/landing.html"):
    with open(f"{RESULTS}/landing.html") as _fh:
        config["_landing_html"] = _fh.read()
#: the papers' published values (references/README.md)
REFERENCES = os.path.join(workflow.basedir, "references")
_skipped = []
RUNS = expand_runs(CFG, _skipped)
for _msg in _skipped:
    sys.stderr.write(f"rodpack: {_msg}\n")


wildcard_constraints:
    study="[a-z][a-z0-9_]*",
    variant="[a-z0-9][a-z0-9_.-]*",
    seed="[0-9]+",


def case_of(wildcards):
    """The validated case of a (study, variant, seed)."""
    return CFG["_cases"][(wildcards.study, wildcards.variant, int(wildcards.seed))]


def engine_setting(engine, key, default):
    return CFG.get("engines", {}).get(engine, {}).get(key, default)


def run_dirs(study=None, variant=None):
    return [
        f"{RESULTS}/{r.run_dir}"
        for r in RUNS
        if (study is None or r.study == study) and (variant is None or r.variant == variant)
    ]


def study_variants():
    return sorted({(r.study, r.variant) for r in RUNS})


def restitution_case():
    """case.yaml of the first tapping run of glued rods on LAMMPS (its contact law drives
    the restitution check), or None."""
    for r in sorted(RUNS, key=lambda r: (r.study, r.variant, r.seed)):
        case = CFG["_cases"][(r.study, r.variant, r.seed)]
        if (r.engine == "lammps" and case["protocol"]["name"] == "tapping"
                and case["particles"]["aspect_ratio"] > 0):
            return f"{RESULTS}/{r.study}/{r.variant}/seed{r.seed}/case.yaml"
    return None


#: case parameters a deposition study derives from its Bond number (the law stiffened with
#: the cohesion, by hand or by contact.bond_stiffening, whose 'factor' is s) or does not
#: analyse
FOLLOW_BOND_NUMBER = {"k_n", "k_t", "gamma_n", "gamma_t", "dt", "thermo_every", "dump_every",
                      "factor"}


def deposit_trend(study):
    """Whether a deposition study gets a trends figure: its variants differ in the aspect
    ratio, or in the Bond number and what follows from it alone (not, e.g., in the wall
    friction or the feed, which a line through the Bond numbers would mix up)."""
    params = set(varying_parameters(CFG, study))
    return "alpha" in params or params - FOLLOW_BOND_NUMBER == {"bond_number"}


def modes_studies():
    """The studies whose stable states get their vibrational modes (rule plot_modes):
    2-D harmonic ``jammed`` studies run on pysim."""
    out = []
    for study in sorted({s for s, _ in study_variants()}):
        if CFG["studies"][study]["case"]["protocol"]["name"] != "jammed":
            continue
        cases = [c for k, c in CFG["_cases"].items() if k[0] == study]
        if any(c["particles"].get("dimension", 3) == 2 and c["contact"]["law"] == "harmonic"
               for c in cases) and any(r.study == study and r.engine == "pysim" for r in RUNS):
            out.append(study)
    return out


def get_final_output():
    out = [f"{RESULTS}/summary.csv", f"{RESULTS}/comparison.csv", f"{RESULTS}/failures.csv",
           f"{RESULTS}/vs_paper.csv", f"{RESULTS}/landing.html"]
    if any(r.engine.startswith("lammps") and CFG["_cases"][(r.study, r.variant, r.seed)]["particles"]
           ["aspect_ratio"] > 0 for r in RUNS):
        out.append(f"{RESULTS}/body_check/body_check.png")  # rods on LAMMPS: check its bodies
    if restitution_case():  # tapped glued rods: check their side-by-side restitution
        out.append(f"{RESULTS}/restitution_check/restitution_check.png")
    protocol = {s: st["case"]["protocol"]["name"] for s, st in CFG["studies"].items()}
    tapping = {s for s, name in protocol.items() if name == "tapping"}
    deposit = {s for s, name in protocol.items() if name == "deposit"}
    hard = set(hard_studies())
    for study in sorted({s for s, _ in study_variants()}):
        if study in hard:  # closest jamming densities against the compression rate
            out += [f"{RESULTS}/{study}/figures/closest_jamming.png",
                    f"{RESULTS}/{study}/closest_jamming.csv"]
            continue
        if study in tapping:
            out.append(f"{RESULTS}/{study}/figures/tapping.png")
            out += [f"{RESULTS}/{study}/figures/sets.png", f"{RESULTS}/{study}/sets.csv"]
        elif study in deposit:
            out.append(f"{RESULTS}/{study}/figures/deposit.png")
            out.append(f"{RESULTS}/{study}/figures/janssen.png")  # against the paper's fits
            if deposit_trend(study):  # deposits versus d = 1 + alpha or the Bond number
                out.append(f"{RESULTS}/{study}/figures/trends.png")
        elif varying_parameters(CFG, study):
            out.append(f"{RESULTS}/{study}/figures/trends.png")
        cases = [c for k, c in CFG["_cases"].items() if k[0] == study]
        if any(c["particles"].get("dimension", 3) == 2 and c["particles"]["aspect_ratio"] > 0
               for c in cases) and study not in tapping | deposit:
            out.append(f"{RESULTS}/{study}/figures/contact_angles.png")  # 2-D rods: P(varphi)
        if protocol[study] == "growth":  # the runs of each aspect ratio across the rates
            for alpha in growth_groups(study):
                out += [f"{RESULTS}/{study}/figures/growth_alpha{alpha}.png",
                        f"{RESULTS}/{study}/growth_alpha{alpha}.csv"]
        if study in modes_studies():
            out.append(f"{RESULTS}/{study}/figures/modes.png")  # dynamical matrix
        if study in caging_studies():  # random contacts on one particle, no run needed
            out += [f"{RESULTS}/{study}/caging.csv", f"{RESULTS}/{study}/figures/caging.png"]
        if protocol[study] == "compress" and len({c["particles"]["n"] for c in cases}) > 1 and all(
            c["particles"].get("dimension", 3) == 2 and c["particles"]["aspect_ratio"] > 0
            for c in cases
        ):
            out.append(f"{RESULTS}/{study}/figures/order_scaling.png")  # S_n ~ 1/sqrt(N)
        if (protocol[study] == "compress" and len({k[1] for k in CFG["_cases"] if k[0] == study}) > 1):
            out.append(f"{RESULTS}/{study}/figures/pressure_variants.png")  # p(phi) overlaid
    for study, variant in study_variants():
        if study in deposit:
            out.append(f"{RESULTS}/{study}/figures/{variant}.packing.png")
            continue
        kinds = (["snapshots"] if study in tapping else ["packing"] if study in hard
                 else ["pressure", "contacts", "phi_j", "packing"])
        out += expand(f"{RESULTS}/{study}/figures/{variant}.{{kind}}.png", kind=kinds)
    return out


def growth_groups(study):
    """``{alpha label: run dirs}`` of a growth study's pysim runs, one group per aspect
    ratio (its runs differ in the growth rate: rule growth_rates)."""
    groups = {}
    for r in RUNS:
        case = CFG["_cases"][(r.study, r.variant, r.seed)]
        if r.study == study and r.engine == "pysim" and case["protocol"]["name"] == "growth":
            groups.setdefault(f"{case['particles'].get('aspect_ratio', 0.0):g}", []).append(
                f"{RESULTS}/{r.run_dir}")
    return groups


def caging_studies():
    """The studies with an ``analysis.caging`` block (rule caging_numbers)."""
    return sorted({s for s, _ in study_variants()
                   if "caging" in CFG["studies"][s].get("analysis", {})})


def caging_args(study):
    """Command-line options of workflows/scripts/caging_numbers.py from a study's
    ``analysis.caging`` block."""
    spec = CFG["studies"][study]["analysis"]["caging"]
    out = [f"--trials {int(spec['trials'])}", f"--seed {int(spec.get('seed', 2024))}"]
    for key in ("alphas_3d", "alphas_2d"):
        if spec.get(key):
            alphas = [f"{float(a):g}" for a in spec[key]] + (["inf"] if spec.get("infinite_rods")
                                                              else [])
            out.append(f"--{key.replace('_', '-')} " + " ".join(alphas))
    return " ".join(out)


def hard_studies():
    """The studies of hard spheres (protocols ls, mls, fb: rule closest_jamming)."""
    return sorted({s for s, _ in study_variants()
                   if CFG["studies"][s]["case"]["protocol"]["name"] in HARD_SPHERE_PROTOCOLS})
