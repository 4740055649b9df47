"""A case: one physical system and protocol, as one YAML file (``case.schema.yaml`` beside
this module) that every engine reads. Loading fills in the schema's defaults, checks
physical consistency and derives the contact parameters the engines share; a bad value
raises :class:`ConfigError` whose message is one line naming the file, the key, the value
and what is allowed.
"""
from __future__ import annotations

import copy
import functools
import hashlib
import json
import math
import os
import re
from pathlib import Path

import jsonschema
import yaml

SCHEMA_DIR = Path(__file__).resolve().parent
#: RSA saturates near 0.38 for spheres; insertion is refused above this
PHI_INSERT_MAX = 0.35
#: memory per particle (or glued sphere) of a run and its analysis, bytes
BYTES_PER_PARTICLE = 2048
#: random sequential addition of disks saturates near 0.547
PHI_INSERT_MAX_2D = 0.5
#: time step must stay below this fraction of the binary contact time
DT_MAX_FRACTION = 0.1


class ConfigError(ValueError):
    """A configuration or case file is invalid; the message is one line."""


class DuplicateKeyError(yaml.constructor.ConstructorError):
    """A mapping of a YAML file gives the same key twice (plain YAML loaders keep the last
    silently)."""


class _Loader(yaml.SafeLoader):
    """YAML loader that reads ``1e5`` and ``1.0e-3`` as numbers (plain YAML 1.1 would
    read ``1.0e5`` as a string) and refuses a key given twice in one mapping (merge keys
    ``<<`` may still be overridden, as YAML intends)."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            first = {}
            for key_node, _value in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=True)
                line = key_node.start_mark.line + 1
                try:
                    if key in first:
                        raise DuplicateKeyError(
                            None, None, f"key {key!r} is given twice in one mapping (lines "
                            f"{first[key]} and {line}); keep one", key_node.start_mark)
                    first[key] = line
                except TypeError:
                    continue  # an unhashable key: SafeLoader reports it itself
        return super().construct_mapping(node, deep=deep)


_FLOAT_RE = re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
                  |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
                  |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
                  |[-+]?\.(?:inf|Inf|INF)
                  |\.(?:nan|NaN|NAN))$""", re.X)
_Loader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT_RE, list("-+0123456789."))


def coerce_numbers(obj):
    """Turn strings that YAML 1.1 left unparsed but that are numbers (``"1.0e5"``, as
    Snakemake's own loader leaves them) into floats, recursively."""
    if isinstance(obj, dict):
        return {k: coerce_numbers(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [coerce_numbers(v) for v in obj]
    if isinstance(obj, str) and _FLOAT_RE.match(obj.strip()) and obj.strip()[:1] != ".":
        try:
            return float(obj)
        except ValueError:  # "-.inf": YAML's spelling, not Python's
            return obj
    return obj


def read_yaml(path):
    """Load a YAML file with :class:`_Loader`; errors become one-line :class:`ConfigError`."""
    path = Path(path)
    try:
        with open(path) as fh:
            return yaml.load(fh, Loader=_Loader)
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such file") from None
    except DuplicateKeyError as exc:
        raise ConfigError(f"{path}:{exc.problem_mark.line + 1}: {exc.problem}") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f":{mark.line + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ConfigError(f"{path}{where}: not valid YAML: {problem}") from None


@functools.lru_cache(maxsize=None)
def load_schema(path) -> dict:
    """A JSON schema written as YAML, parsed once per process (every case of a profile is
    validated against it; the validators only read it)."""
    with open(path) as fh:
        return yaml.safe_load(fh)


def _with_defaults(validator_class):
    """A validator that also fills in ``default`` values of missing properties."""
    validate_properties = validator_class.VALIDATORS["properties"]

    def set_defaults(validator, properties, instance, schema):
        if isinstance(instance, dict):
            for prop, sub in properties.items():
                if "default" in sub and prop not in instance:
                    instance[prop] = copy.deepcopy(sub["default"])
        yield from validate_properties(validator, properties, instance, schema)

    base_types = validator_class.TYPE_CHECKER

    def finite_number(checker, instance):
        # NaN passes every minimum and maximum (each comparison is false) and inf every
        # minimum: a number in a case or configuration must be finite
        return base_types.is_type(instance, "number") and (
            not isinstance(instance, float) or math.isfinite(instance))

    return jsonschema.validators.extend(validator_class, {"properties": set_defaults},
                                        type_checker=base_types.redefine("number", finite_number))


Validator = _with_defaults(jsonschema.Draft202012Validator)


def _bounds(s: dict) -> str:
    """The bounds of a number schema, ``">= 0 and <= 10"`` (empty without bounds)."""
    parts = []
    if "minimum" in s:
        parts.append(f">= {s['minimum']}")
    if "exclusiveMinimum" in s:
        parts.append(f"> {s['exclusiveMinimum']}")
    if "maximum" in s:
        parts.append(f"<= {s['maximum']}")
    if "exclusiveMaximum" in s:
        parts.append(f"< {s['exclusiveMaximum']}")
    return " and ".join(parts)


def _allowed(error) -> str:
    s = error.schema
    v = error.validator
    if isinstance(error.instance, float) and not math.isfinite(error.instance) and (
            v != "enum" and s.get("type") in ("number", "integer", None)):
        kind = "an integer" if s.get("type") == "integer" else "a finite number"
        return " ".join([kind, _bounds(s)]).strip()
    if v == "enum":
        return "one of " + ", ".join(repr(x) for x in s["enum"])
    if v == "type":
        return f"a value of type {s['type']}"
    if v in ("minimum", "exclusiveMinimum", "maximum", "exclusiveMaximum"):
        return "a number " + _bounds(s)
    if v == "additionalProperties":
        allowed = sorted(s.get("properties", {}))
        return "only the keys " + ", ".join(allowed) if allowed else "no other keys"
    if v == "required":
        return "the keys " + ", ".join(s["required"])
    if v in ("minItems", "maxItems"):
        return f"a list with {v[:3]} {s[v]} items"
    if v == "minProperties":
        return f"at least {s[v]} entries"
    if v == "pattern":
        return f"a name matching {s['pattern']}"
    return error.message


def _key(path) -> str:
    return ".".join(str(p) for p in path) or "(top level)"


def raise_first(errors, source: str, prefix=()):
    errors = sorted(errors, key=lambda e: (len(e.path), list(map(str, e.path))))
    if not errors:
        return
    e = errors[0]
    path = list(prefix) + list(e.absolute_path)
    if e.validator == "additionalProperties":
        extra = sorted(set(e.instance) - set(e.schema.get("properties", {})))
        key = _key(path + [extra[0]]) if extra else _key(path)
        raise ConfigError(f"{source}: unknown key '{key}'; allowed here: {_allowed(e)[14:]}")
    if e.validator == "required":
        missing = [k for k in e.validator_value if k not in e.instance]
        raise ConfigError(f"{source}: missing key '{_key(path + missing[:1])}'")
    if "propertyNames" in e.relative_schema_path:
        raise ConfigError(f"{source}: {_key(path)}: name {e.instance!r} is not allowed; use "
                          f"{_allowed(e)}")
    raise ConfigError(f"{source}: {_key(path)} = {e.instance!r} is not allowed; use {_allowed(e)}")


def check_finite(obj, source: str, path=()):
    """Refuse NaN and infinity anywhere (the schema's number type refuses them where it
    types a value; this catches the rest)."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            check_finite(v, source, tuple(path) + (k,))
    elif isinstance(obj, list):
        for k, v in enumerate(obj):
            check_finite(v, source, tuple(path) + (k,))
    elif isinstance(obj, float) and not math.isfinite(obj):
        raise ConfigError(f"{source}: {_key(path)} = {obj} is not allowed; use a finite number")


def deep_merge(base: dict, override: dict) -> dict:
    """Recursively merge ``override`` into a copy of ``base``."""
    out = copy.deepcopy(base)
    for k, v in override.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = deep_merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


# -- cases ----------------------------------------------------------------------------------
def frictional(contact: dict) -> bool:
    """Whether a ``contact`` block has friction between grains or at the walls (then a
    tangential spring is needed)."""
    return max(contact.get("friction", 0.0), contact.get("wall_friction", 0.0)) > 0


def contact_time(k_n: float, gamma_n: float, m_eff: float) -> float:
    """Binary contact time of the linear spring-dashpot (science.md section 3):
    ``t_c = pi / sqrt(k/m_eff - (gamma/(2 m_eff))^2)``; the undamped value if overdamped."""
    w2 = k_n / m_eff - (gamma_n / (2 * m_eff)) ** 2
    if w2 <= 0:
        w2 = k_n / m_eff
    return math.pi / math.sqrt(w2)


def validate_case(case: dict, source: str = "case", prefix=()) -> dict:
    """Validate a case (schema, the protocol's own schema, then physical consistency);
    return it with defaults filled in."""
    case = coerce_numbers(copy.deepcopy(case))
    schema = load_schema(SCHEMA_DIR / "case.schema.yaml")
    raise_first(Validator(schema).iter_errors(case), source, prefix)
    name = case["protocol"]["name"]
    sub = dict(schema["$defs"][f"protocol_{name}"])
    raise_first(Validator(sub).iter_errors(case["protocol"]), source,
                 tuple(prefix) + ("protocol",))
    check_finite(case, source, prefix)
    _check_case(case, source, ".".join(map(str, prefix)) + "." if prefix else "")
    return case


def physical_memory() -> int:
    """Bytes of physical memory of this machine (0 if unknown)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 0


def size_extremes(diameter: dict) -> tuple[float, float, float]:
    """``(smallest, mean, largest)`` diameter a distribution will produce in practice
    (lognormal: mean +- 4 sigma, bounded below by a quarter of the mean)."""
    mean = diameter["mean"]
    dist = diameter.get("distribution", "mono")
    if dist == "lognormal":
        sig = diameter.get("sigma", 0.0)
        return max(mean * (1 - 4 * sig), 0.25 * mean), mean, mean * (1 + 4 * sig)
    if dist == "bidisperse":
        big = mean * diameter.get("ratio", 1.4)
        f = diameter.get("fraction_big", 0.5)
        return mean, (1 - f) * mean + f * big, big
    return mean, mean, mean


def particle_measure(d: float, alpha: float, dimension: int) -> float:
    """Volume (3-D) or area (2-D) of a spherocylinder of diameter ``d`` and ``L = alpha d``."""
    length = alpha * d
    if dimension == 2:
        return d * length + math.pi * d * d / 4
    return math.pi * d * d * length / 4 + math.pi * d**3 / 6


#: the hard-sphere protocols (pysim.hard): no contact law, spheres in a periodic cube
HARD_SPHERE_PROTOCOLS = ("ls", "mls", "fb")
#: pysim's hard-sphere cell grid: the packing fraction a case must be able to reach, the
#: fewest cells per side, and the neighbour lists' skin in mean diameters
#: (pysim.hard.cells.MIN_CELLS, pysim.hard.edmd.SKIN)
HARD_PHI_CAP = 0.78
HARD_MIN_CELLS = 3
HARD_SKIN = 0.2


def _check_hard(case: dict, source: str, at: str):
    """A hard-sphere case: spheres of mean nominal diameter 1 in a periodic cube, no
    contact law, no walls, no gravity, enough of them for the cell grid."""
    p = case["particles"]
    pr = case["protocol"]
    name = pr["name"]
    for key, bad in (("contact", "contact" in case), ("container", "container" in case),
                     ("gravity", case.get("gravity", 0.0) != 0.0)):
        if bad:
            raise ConfigError(f"{source}: {at}{key} does not apply to the hard-sphere protocol "
                              f"{name} (no contact law, walls or gravity); remove it")
    if p["dimension"] != 3 or p["aspect_ratio"] != 0:
        raise ConfigError(f"{source}: {at}particles: protocol {name} is for 3-D spheres; got "
                          f"dimension {p['dimension']}, aspect_ratio {p['aspect_ratio']}")
    d = p["diameter"]
    if d["mean"] != 1.0:
        raise ConfigError(f"{source}: {at}particles.diameter.mean = {d['mean']} is not allowed "
                          f"for protocol {name}; use 1 (lengths in mean nominal diameters, "
                          "the unit of the compression rate and temperature)")
    if d.get("distribution", "mono") not in ("mono", "lognormal"):
        raise ConfigError(f"{source}: {at}particles.diameter.distribution = "
                          f"{d['distribution']!r} is not allowed for protocol {name}; use mono "
                          "or lognormal")
    if d.get("distribution", "mono") != "lognormal" and d.get("sigma", 0):
        raise ConfigError(f"{source}: {at}particles.diameter.sigma = {d['sigma']} needs "
                          "distribution: lognormal (mono diameters have sigma 0)")
    # the cell grid: cells no smaller than the largest diameter at HARD_PHI_CAP plus the
    # neighbour lists' skin
    phi_nom = pr["phi_nominal"]
    sig = d.get("sigma", 0.0)
    side = (p["n"] * math.pi / 6 * (1 + sig**2) ** 3 / phi_nom) ** (1 / 3)
    reach = size_extremes(d)[2] * (HARD_PHI_CAP / phi_nom) ** (1 / 3) + HARD_SKIN
    if side < HARD_MIN_CELLS * reach:
        n_min = math.ceil(p["n"] * (HARD_MIN_CELLS * reach / side) ** 3)
        raise ConfigError(f"{source}: {at}particles.n = {p['n']} is too small for protocol "
                          f"{name}: the box must hold {HARD_MIN_CELLS} cells of the largest "
                          f"diameter and skin per side; use n >= {n_min}")


def _check_case(case: dict, source: str, at: str):
    if case["protocol"]["name"] in HARD_SPHERE_PROTOCOLS:
        _check_hard(case, source, at)
        return
    p = case["particles"]
    c = case["contact"]
    pr = case["protocol"]
    d = p["diameter"]
    dim = p["dimension"]
    alpha = p["aspect_ratio"]
    if d.get("distribution", "mono") != "lognormal" and d.get("sigma", 0):
        raise ConfigError(f"{source}: {at}particles.diameter.sigma = {d['sigma']} needs "
                          "distribution: lognormal (mono diameters have sigma 0)")
    phi_insert = PHI_INSERT_MAX if dim == 3 else PHI_INSERT_MAX_2D
    if pr["phi_init"] > phi_insert:
        raise ConfigError(
            f"{source}: {at}protocol.phi_init = {pr['phi_init']} cannot be reached by random "
            f"insertion in {dim}-D; use a value <= {phi_insert} and compress")
    phi_end = {"compress": pr.get("phi_final"), "jammed": pr.get("phi_max"),
               "quasistatic": pr.get("phi_max"),
               "growth": pr.get("phi_max")}.get(pr["name"], 0.75)
    _derive_contact(case, source, at)
    _stiffen_with_bond(case, source, at)
    _check_container(case, source, at)
    if pr["name"] == "compress":
        if pr["phi_final"] <= pr["phi_init"]:
            raise ConfigError(f"{source}: {at}protocol.phi_final = {pr['phi_final']} must be "
                              f"above phi_init = {pr['phi_init']}")
        has_fast = "phi_fast" in pr
        if has_fast != ("rate_fast" in pr):
            raise ConfigError(f"{source}: {at}protocol: phi_fast and rate_fast go together; "
                              "give both or neither")
        if has_fast and not pr["phi_init"] < pr["phi_fast"] < pr["phi_final"]:
            raise ConfigError(
                f"{source}: {at}protocol.phi_fast = {pr['phi_fast']} must lie between phi_init "
                f"= {pr['phi_init']} and phi_final = {pr['phi_final']}")
        settle = pr.get("settle")
        if settle is not None and alpha > 0:  # LIGGGHTS' settling of rods (workflows/engines/liggghts.py)
            reach = size_extremes(d)[2] * (1.0 + alpha)
            w_min = 2.0 * (reach + 0.2 * d["mean"])
            if settle["width"] <= w_min:
                raise ConfigError(
                    f"{source}: {at}protocol.settle.width = {settle['width']} lets a rod meet its "
                    f"own periodic image; use a width > 2 (L + D + 0.2 D) = {w_min:.4g}")
    if pr["name"] == "growth" and pr["phi_grow"] <= pr["phi_init"]:
        raise ConfigError(f"{source}: {at}protocol.phi_grow = {pr['phi_grow']} must be above "
                          f"phi_init = {pr['phi_init']}")
    if pr["name"] == "growth" and "contraction" in pr and not (
            pr["phi_init"] < pr["contraction"]["phi"] < pr["phi_grow"]):
        raise ConfigError(f"{source}: {at}protocol.contraction.phi = "
                          f"{pr['contraction']['phi']} must lie between phi_init = {pr['phi_init']} and phi_grow = {pr['phi_grow']}")
    if pr["name"] == "growth" and pr["phi_grow"] >= pr["phi_max"]:
        raise ConfigError(f"{source}: {at}protocol.phi_grow = {pr['phi_grow']} must be below "
                          f"phi_max = {pr['phi_max']}")
    if (pr["name"] == "quasistatic" and alpha > 0
            and c.get("spine_contact", "closest") == "closest"
            and pr.get("relaxation", "minimise") == "minimise"):
        # measured: a FIRE-relaxed step of 1024 rods of alpha 1 at p = 1e-3 lost 80 % of its
        # pressure under 1e6 more overdamped steps (docs/studies/jamming_2d.md)
        raise ConfigError(f"{source}: {at}protocol.relaxation = minimise stalls on the kink of "
                          "the rods' closest-point law (contact.spine_contact = closest); use "
                          "relaxation: overdamped, or spine_contact: end_bonds or "
                          "end_bonds_distinct")
    if c.get("wall_cohesion", False) and pr["name"] != "deposit":
        raise ConfigError(f"{source}: {at}contact.wall_cohesion is for the deposit protocol; "
                          f"got protocol {pr['name']}")
    if c.get("spine_contact", "closest") != "closest" and dim != 2:
        raise ConfigError(f"{source}: {at}contact.spine_contact = {c['spine_contact']} is "
                          f"for 2-D rods; got dimension {dim}")
    # the compression switches rules mid-run, which tangential springs cannot follow
    squeeze = pr.get("compress_spine_contact", "closest")
    if squeeze != "closest" and (dim != 2 or c["friction"] > 0 or c.get("bond_number", 0) > 0):
        raise ConfigError(f"{source}: {at}protocol.compress_spine_contact = {squeeze} is for "
                          "2-D frictionless, cohesionless rods (dimension 2, friction 0, no "
                          f"bond_number); got dimension {dim}, friction {c['friction']}")
    if c["friction"] > 0 and not c["k_t"] > 0:
        raise ConfigError(f"{source}: {at}contact.k_t = {c['k_t']} must be > 0 when "
                          f"friction = {c['friction']} > 0 (law {c['law']}; for the linear "
                          f"law it defaults to 2/7 k_n = {KT_PER_KN * c['k_n']:.4g})")
    if c.get("wall_friction", 0.0) > 0 and not c["k_t"] > 0:
        raise ConfigError(f"{source}: {at}contact.k_t = {c['k_t']} must be > 0 when "
                          f"wall_friction = {c['wall_friction']} > 0")
    if pr["name"] == "tapping":
        _check_preparation(pr, source, at)
    # time step against the contact time of the lightest pair
    dmin, dmean, dmax = size_extremes(d)
    m = p["density"] * particle_measure(dmin, alpha, dim)
    k = c["k_n"] / dmin**2 if c["law"] == "harmonic" else c["k_n"]
    if c["law"] in ("hooke", "harmonic"):
        t_c = contact_time(k, c["gamma_n"], 0.5 * m)
        if pr["dt"] > DT_MAX_FRACTION * t_c:
            raise ConfigError(
                f"{source}: {at}protocol.dt = {pr['dt']} is above {DT_MAX_FRACTION} of the "
                f"contact time t_c = {t_c:.3g}; use dt <= {DT_MAX_FRACTION * t_c:.3g} "
                "(t_c/50 is usual)")
    # memory: about 2 KB per particle for pysim and the analysis, per glued sphere for the
    # peers' rods (a rod of aspect ratio alpha is about 4 alpha + 1 spheres)
    need = p["n"] * BYTES_PER_PARTICLE * (4 * alpha + 1)
    have = physical_memory()
    if have and need > have:
        raise ConfigError(
            f"{source}: {at}particles.n = {p['n']} needs about {need / 2**30:.1f} GiB, more than "
            f"this machine's {have / 2**30:.1f} GiB; use fewer particles")
    if "container" in case:
        return
    # the periodic box at the end must hold the longest particle plus the neighbour
    # skin (0.2 of the largest diameter in every protocol) twice: the minimum image
    vol = p["n"] * particle_measure(dmean, alpha, dim)
    side = (vol / phi_end) ** (1 / dim)
    reach = dmax * (1 + alpha) + 0.2 * dmax
    if side < 2.0 * reach:
        n_min = math.ceil(p["n"] * (2.0 * reach / side) ** dim)
        raise ConfigError(
            f"{source}: {at}particles.n = {p['n']} is too small for a periodic box at packing "
            f"fraction {phi_end} (side {side:.3g} < twice the particle length plus skin); "
            f"use n >= {n_min}")


def restitution_law(e_n: float, t_c: float, m_eff: float) -> tuple[float, float]:
    """``(k_n, gamma_n)`` of the linear spring-dashpot with restitution ``e_n`` and contact
    time ``t_c`` for reduced mass ``m_eff`` (science.md section 3): ``zeta = -ln e /
    sqrt(pi^2 + ln^2 e)``, ``omega_0 = pi / (t_c sqrt(1 - zeta^2))``, ``k = m_eff
    omega_0^2``, ``gamma = 2 zeta m_eff omega_0``."""
    if not 0 < e_n <= 1:
        raise ValueError(f"restitution must be in (0, 1], got {e_n}")
    ln_e = math.log(e_n)
    zeta = -ln_e / math.sqrt(math.pi**2 + ln_e**2)
    w0 = math.pi / (t_c * math.sqrt(1.0 - zeta**2))
    return m_eff * w0**2, 2.0 * zeta * m_eff * w0


#: the tangential law derived from a restitution law when the case gives none:
#: ``k_t = 2/7 k_n``, ``gamma_t = gamma_n / 2``
KT_PER_KN = 2.0 / 7.0
GT_PER_GN = 0.5


def _derive_contact(case: dict, source: str, at: str):
    """Fill ``k_n`` and ``gamma_n`` (and, with friction, ``k_t``/``gamma_t`` defaults) from
    ``restitution`` and ``contact_time``; a case that gives both forms must agree."""
    c = case["contact"]
    p = case["particles"]
    has_e = "restitution" in c
    if has_e != ("contact_time" in c):
        raise ConfigError(f"{source}: {at}contact: restitution and contact_time go together; "
                          "give both or neither")
    if not has_e:
        if "k_n" not in c:
            raise ConfigError(f"{source}: {at}contact.k_n is required (or give restitution and "
                              "contact_time)")
        if frictional(c) and c["law"] == "hooke" and not c.get("k_t", 0.0) > 0:
            # the linear law's usual tangential spring (equal normal and tangential
            # periods of a sphere contact), and half the normal damping
            c["k_t"] = KT_PER_KN * c["k_n"]
            if not c.get("gamma_t", 0.0) > 0:
                c["gamma_t"] = GT_PER_GN * c.get("gamma_n", 0.0)
        return
    if c["law"] != "hooke":
        raise ConfigError(f"{source}: {at}contact.restitution needs law: hooke, not "
                          f"{c['law']!r} (give k_n and gamma_n instead)")
    m = p["density"] * particle_measure(p["diameter"]["mean"], p["aspect_ratio"], p["dimension"])
    k_n, gamma_n = restitution_law(c["restitution"], c["contact_time"], 0.5 * m)
    derived = {"k_n": k_n, "gamma_n": gamma_n}
    if frictional(c):
        derived["k_t"] = c["k_t"] if c.get("k_t", 0.0) > 0 else KT_PER_KN * k_n
        derived["gamma_t"] = c["gamma_t"] if c.get("gamma_t", 0.0) > 0 else GT_PER_GN * gamma_n
    for key in ("k_n", "gamma_n"):
        given = c.get(key)
        if key == "gamma_n" and given == 0.0 and "k_n" not in c:
            given = None  # the schema default, not a value the user gave
        if given is not None and not math.isclose(given, derived[key], rel_tol=1e-9):
            raise ConfigError(
                f"{source}: {at}contact.{key} = {given} contradicts restitution "
                f"{c['restitution']} and contact_time {c['contact_time']} (which give "
                f"{derived[key]:.6g}); give one form only")
    c.update(derived)


#: keys of a tapping protocol's ``preparation`` block that only mode ``free`` uses
FREE_KEYS = ("ke_stop", "check_time", "max_time")


def _check_preparation(pr: dict, source: str, at: str):
    """A tapping protocol's ``preparation``: mode free needs ``ke_stop`` and ``max_time``
    (``check_time`` defaults to a quarter of the base period) and tests at least once per
    step and before ``max_time``; mode capped takes none of them."""
    prep = pr.get("preparation")
    if prep is None:
        return
    key = f"{at}protocol.preparation"
    if prep["mode"] != "free":
        extra = [k for k in FREE_KEYS if k in prep]
        if extra:
            raise ConfigError(f"{source}: {key}.{extra[0]} is used by mode free only, not "
                              f"{prep['mode']!r}; remove it")
        return
    for k in ("ke_stop", "max_time"):
        if k not in prep:
            raise ConfigError(f"{source}: missing key '{key}.{k}' (required by mode free)")
    prep.setdefault("check_time", 0.25 / pr["frequency"])
    if prep["check_time"] < pr["dt"]:
        raise ConfigError(f"{source}: {key}.check_time = {prep['check_time']} is below the time "
                          f"step dt = {pr['dt']}; use check_time >= dt")
    if prep["max_time"] < prep["check_time"]:
        raise ConfigError(f"{source}: {key}.max_time = {prep['max_time']} is below check_time = "
                          f"{prep['check_time']:g}; use max_time >= check_time")


def _stiffen_with_bond(case: dict, source: str, at: str):
    """``contact.bond_stiffening``: above the Bond number ``reference``, with ``s =
    bond_number / reference``, multiply ``k_n`` and ``k_t`` by ``s``, ``gamma_n`` and
    ``gamma_t`` by ``sqrt(s)`` and ``protocol.dt`` by ``s^(-2/5)`` (a Hertz contact pressed
    by ``F_c = Bo_g m g`` then overlaps as at the reference; its period shrinks as
    ``s^(-2/5)``), and record ``factor = s``. A case that has ``factor`` was stiffened
    when it was first validated (its ``case.yaml`` is read again by the engines) and is
    left as it is, once ``factor`` is checked against the Bond number."""
    c = case["contact"]
    st = c.get("bond_stiffening")
    if st is None:
        return
    s = max(c.get("bond_number", 0.0) / st["reference"], 1.0)
    if "factor" in st:
        if not math.isclose(st["factor"], s, rel_tol=1e-12):
            raise ConfigError(
                f"{source}: {at}contact.bond_stiffening.factor = {st['factor']} does not match "
                f"bond_number / reference = {s:.12g}; remove factor (validation writes it)")
        return
    for key in ("k_n", "k_t"):
        c[key] = c[key] * s
    for key in ("gamma_n", "gamma_t"):
        c[key] = c[key] * math.sqrt(s)
    case["protocol"]["dt"] = case["protocol"]["dt"] * s ** -0.4
    st["factor"] = s


def _check_feed(case: dict, source: str, at: str):
    """``protocol.feed`` (deposits): 2-D only, not with the rain, at most one grain per
    step, and an entry line that a grain fits under and that lies above the deposit even
    at packing fraction 1."""
    pr = case["protocol"]
    feed = pr["feed"]
    p = case["particles"]
    if p["dimension"] != 2:
        raise ConfigError(f"{source}: {at}protocol.feed is implemented in 2-D only (pysim); "
                          f"got particles.dimension = {p['dimension']}: use dimension 2, or "
                          "the random column (phi_init, rain_speed) in 3-D")
    if "rain_speed" in pr:
        raise ConfigError(f"{source}: {at}protocol.feed and protocol.rain_speed exclude each "
                          "other (the feed replaces the raining column); remove one")
    if feed["rate"] * pr["dt"] > 1.0:
        raise ConfigError(f"{source}: {at}protocol.feed.rate = {feed['rate']} feeds more than "
                          f"one grain per step (dt = {pr['dt']}); use rate <= {1.0 / pr['dt']:.6g}")
    dmax = size_extremes(p["diameter"])[2]
    reach = 0.5 * dmax * (1.0 + p["aspect_ratio"])
    w = case["container"]["width"]
    filled = p["n"] * particle_measure(size_extremes(p["diameter"])[1], p["aspect_ratio"], 2) / w
    if feed["height"] <= filled + reach:
        raise ConfigError(
            f"{source}: {at}protocol.feed.height = {feed['height']} is not above the deposit "
            f"even at packing fraction 1 ({filled:.4g}) plus half a grain ({reach:.4g}); use a "
            f"height > {filled + reach:.4g} (above the expected deposit)")


def _check_container(case: dict, source: str, at: str):
    """Container cases: tapping needs a 3-D cylinder, deposition a box, both gravity; the
    container must be wider than the longest grain; cohesion by a Bond number needs
    gravity."""
    pr = case["protocol"]
    p = case["particles"]
    cont = case.get("container")
    if case["contact"].get("bond_number", 0.0) > 0 and not case["gravity"] > 0:
        raise ConfigError(f"{source}: {at}contact.bond_number = {case['contact']['bond_number']} "
                          f"needs gravity > 0 (F_c = Bo_g m g), not {case['gravity']}")
    if pr["name"] == "deposit":
        if cont is None or cont["shape"] != "box":
            raise ConfigError(f"{source}: {at}protocol 'deposit' needs container: "
                              "{shape: box, width: ...}")
        if not case["gravity"] > 0:
            raise ConfigError(f"{source}: {at}gravity = {case['gravity']} must be > 0 for "
                              "protocol 'deposit'")
    elif pr["name"] == "tapping":
        if cont is None:
            raise ConfigError(f"{source}: {at}container is required by protocol 'tapping' "
                              "(e.g. container: {shape: cylinder, diameter: 8.0e-3})")
        if not case["gravity"] > 0:
            raise ConfigError(f"{source}: {at}gravity = {case['gravity']} must be > 0 for "
                              "protocol 'tapping'")
        if p["dimension"] != 3:
            raise ConfigError(f"{source}: {at}particles.dimension = {p['dimension']}: protocol "
                              "'tapping' is 3-D (a cylinder); use 3")
        if cont["shape"] != "cylinder":
            raise ConfigError(f"{source}: {at}container.shape = {cont['shape']!r}: protocol "
                              "'tapping' runs in a cylinder; use 'cylinder'")
    elif cont is not None:
        raise ConfigError(f"{source}: {at}container is only used by protocols 'tapping' and "
                          f"'deposit', not {pr['name']!r}; remove it")
    if cont is None:
        return
    key = "diameter" if cont["shape"] == "cylinder" else "width"
    other = "width" if key == "diameter" else "diameter"
    if key not in cont:
        raise ConfigError(f"{source}: {at}container.{key} is required for shape "
                          f"{cont['shape']!r}")
    if other in cont:
        raise ConfigError(f"{source}: {at}container.{other} is not used by shape "
                          f"{cont['shape']!r} (it takes {key}); remove it")
    dmax = size_extremes(p["diameter"])[2]
    longest = dmax * (1.0 + p["aspect_ratio"])
    if cont[key] <= 1.5 * longest:
        raise ConfigError(
            f"{source}: {at}container.{key} = {cont[key]} must exceed 1.5 times the "
            f"longest grain (L + D = {longest:.4g}); use a wider container")
    if "feed" in pr:
        _check_feed(case, source, at)


def load_case(path) -> dict:
    """Read and validate one case file (YAML)."""
    case = read_yaml(path)
    if not isinstance(case, dict):
        raise ConfigError(f"{path}: a case is a mapping of keys, got {type(case).__name__}")
    return validate_case(case, str(path))


def case_hash(case: dict) -> str:
    """Short stable hash of a case (canonical JSON), recorded with every result."""
    text = json.dumps(case, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:12]
