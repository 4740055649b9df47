"""Which engine runs what, and how: one adapter per (engine, shape, protocol) that an
engine supports, saying which deck runs it, how the deck's ``-var`` values are built,
which data file the deck reads, how its output becomes the common format, whether a
stopped run resumes, and the case options the deck cannot do (its limits).

A combination missing from :data:`ADAPTERS` is not supported; :func:`supports` says so in
one line naming what the engine does run. :mod:`workflows.engines.driver` runs an adapter,
:mod:`workflows.capabilities` prints the matrix the table implies on the shipped cases.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from workflows.engines import common, lammps, liggghts, pysim, restarts
from workflows.engines.common import SHAPES, EngineError, inertial_only, shape
from workflows.engines.data import write_body_data, write_glued_data
from workflows.engines.feed import write_feed

#: a limit: ``(engine, case) -> None`` when the deck can run the case, else the reason
Limit = Callable[[str, dict], "str | None"]


@dataclass(frozen=True)
class DataWriter:
    """A data file written from ``init.data`` for a deck: ``write(init, out, case)``
    returns the particles' total volume (3-D) or area (2-D), kept in ``measure_file`` and
    passed to the deck as ``-var vrods`` (3-D) or ``arods`` (2-D)."""

    write: Callable
    file: str
    measure_file: str


GLUED = DataWriter(write_glued_data, "glued.data", "vrods.txt")
BODIES = DataWriter(write_body_data, "bodies.data", "measure.txt")
#: the 2-D fed deposit deck creates its grains from a feed file (pysim's entries)
FEED = DataWriter(write_feed, "feed.csv", "measure.txt")


@dataclass(frozen=True)
class Adapter:
    """How ``engine`` runs cases of ``shape`` under ``protocol``.

    ``deck``: path under ``inputs/`` (None for pysim, which the runner starts itself);
    ``variables(case)``: the deck's ``-var`` values; ``clip(case)``: those of
    ``contact.limit_damping`` (None: the deck's law has no clip to set); ``writer``: the
    data file the deck reads (None: ``init.data`` itself, or the deck inserts its own
    particles); ``convert(work, case, data)``: the output in ``work`` -> common format
    there, returns ``{"dropped": ...}``; ``command(deck, outdir, ranks, args)``: the
    engine's command line; ``version``: regex of its version line; ``latest_restart(work)``:
    the newest complete restart file (None: a stopped run starts over);
    ``resume_vars(work, step)``: what the deck needs besides the restart file;
    ``limits``: checked in order after the engine's own (:data:`ENGINE_LIMITS`);
    ``one_rank``: runs on one MPI rank whatever is asked (LIGGGHTS' multisphere bodies);
    ``settles``: a compression case run as gravity settling; ``reports_settled``: the
    record says whether the bed settled; ``record``: fixed entries of the run record.
    """

    engine: str
    shape: str
    protocol: str
    deck: str | None
    variables: Callable | None = None
    clip: Callable | None = None
    writer: DataWriter | None = None
    convert: Callable | None = None
    command: Callable | None = None
    version: str = ""
    latest_restart: Callable | None = None
    resume_vars: Callable | None = None
    limits: tuple[Limit, ...] = ()
    one_rank: bool = False
    settles: bool = False
    reports_settled: bool = False
    record: dict = field(default_factory=dict)

    @property
    def resumes(self) -> bool:
        """Whether a stopped run of this adapter resumes (else it starts over)."""
        return self.latest_restart is not None

    def deck_path(self) -> Path:
        """The deck file (under ``RODPACK_INPUTS`` when that is set)."""
        if self.deck is None:
            raise EngineError(f"{self.engine} has no deck: workflows.runner runs it itself "
                              "(python -m pysim run)")
        return common.INPUTS / self.deck


def _case_only(check: Callable[[dict], "str | None"]) -> Limit:
    """A limit from a check that needs the case only."""
    def limit(engine: str, case: dict) -> str | None:
        return check(case)

    limit.__doc__ = check.__doc__
    return limit


_LAMMPS = dict(command=lammps.command, version=lammps.VERSION,
               latest_restart=restarts.latest_restart)
_LIGGGHTS = dict(command=liggghts.command, version=liggghts.VERSION)
_BODY_NOTE = {"contact_forces": "reconstructed from the overlaps with the contact law "
                                "(no per-contact output for LAMMPS body particles)"}

_PEERS = [
    # LAMMPS: spheres, and rods as spheres glued into rigid bodies (2-D: glued disks)
    Adapter("lammps", "spheres", "compress", "lammps/in.spheres.compress",
            variables=lammps.compress_spheres_vars, clip=lammps.clip_vars, writer=None,
            convert=lammps.convert_spheres,
            limits=(inertial_only,), **_LAMMPS),
    Adapter("lammps", "rods", "compress", "lammps/in.rods.compress",
            variables=lammps.compress_rods_vars, clip=lammps.clip_vars, writer=GLUED,
            convert=lammps.convert_glued,
            limits=(inertial_only,), **_LAMMPS),
    # the 2-D deck's soft harmonic law has no dashpot: nothing to clip
    Adapter("lammps", "disks 2-D", "compress", "lammps/in.2d.compress",
            variables=lammps.deck_vars_2d, clip=None, writer=GLUED,
            convert=lammps.convert_glued,
            limits=(lammps.harmonic_2d_only,), **_LAMMPS),
    Adapter("lammps", "rods 2-D", "compress", "lammps/in.2d.compress",
            variables=lammps.deck_vars_2d, clip=None, writer=GLUED,
            convert=lammps.convert_glued,
            limits=(lammps.harmonic_2d_only,), **_LAMMPS),
    Adapter("lammps", "rods", "tapping", "lammps/in.rods.tap",
            variables=lammps.tap_deck_vars, clip=lammps.clip_vars, writer=GLUED,
            convert=lammps.convert_glued, **_LAMMPS),
    Adapter("lammps", "rods", "deposit", "lammps/in.rods.deposit",
            variables=lammps.deposit_deck_vars, clip=lammps.clip_vars, writer=GLUED,
            convert=lammps.convert_glued,
            resume_vars=lammps.deposit_resume_vars, reports_settled=True, **_LAMMPS),
    # 2-D rods fed one at a time from pysim's entries (the feed file is the deck's 'data')
    Adapter("lammps", "rods 2-D", "deposit", "lammps/in.2d.rods.deposit",
            variables=lammps.deposit_2d_vars, clip=lammps.clip_vars, writer=FEED,
            convert=lammps.convert_glued, limits=(lammps.fed_2d_deposit,),
            resume_vars=lammps.deposit_resume_vars, reports_settled=True, **_LAMMPS),
    # LAMMPS body particles: one rounded segment per rod, contacts found afterwards; the
    # body pair styles have no damping clip (contact.limit_damping is refused)
    Adapter("lammps-body", "rods", "compress", "lammps/in.rods.body.compress",
            variables=lammps.body_rods_vars, clip=None, writer=BODIES,
            convert=lammps.convert_bodies,
            limits=(lammps.body_rods_law, inertial_only), record=_BODY_NOTE, **_LAMMPS),
    Adapter("lammps-body", "rods 2-D", "compress", "lammps/in.2d.body.compress",
            variables=lammps.body_2d_vars, clip=None, writer=BODIES,
            convert=lammps.convert_bodies,
            limits=(lammps.harmonic_2d_only,), record=_BODY_NOTE, **_LAMMPS),
    # LIGGGHTS: spheres from init.data; rods as multisphere bodies its decks insert
    Adapter("liggghts", "spheres", "compress", "liggghts/in.spheres.compress",
            variables=liggghts.compress_spheres_vars, clip=liggghts.clip_vars, writer=None,
            convert=liggghts.convert_spheres,
            limits=(inertial_only,), **_LIGGGHTS),
    Adapter("liggghts", "rods", "compress", "liggghts/in.rods.settle",
            variables=liggghts.liggghts_settle_vars, clip=liggghts.clip_vars, writer=None,
            convert=liggghts.convert_settle,
            limits=(inertial_only, _case_only(liggghts.liggghts_settle_support)),
            one_rank=True, settles=True, reports_settled=True, **_LIGGGHTS),
    Adapter("liggghts", "rods", "tapping", "liggghts/in.rods.tap",
            variables=liggghts.liggghts_tap_vars, clip=liggghts.clip_vars, writer=None,
            convert=liggghts.convert_tap,
            latest_restart=liggghts.liggghts_latest_restart,
            limits=(_case_only(liggghts.liggghts_tap_support),), one_rank=True, **_LIGGGHTS),
    Adapter("liggghts", "rods", "deposit", "liggghts/in.rods.deposit",
            variables=liggghts.liggghts_deposit_vars, clip=liggghts.clip_vars, writer=None,
            convert=liggghts.convert_deposit,
            limits=(_case_only(liggghts.liggghts_deposit_support),), one_rank=True,
            reports_settled=True, **_LIGGGHTS),
]
#: pysim runs every shape under every protocol, from its own checkpoint when stopped
_PYSIM = [Adapter("pysim", s, p, None, latest_restart=pysim.latest_checkpoint)
          for p in pysim.PROTOCOLS for s in SHAPES]

#: the table: ``(engine, shape, protocol) -> Adapter``, every supported combination
ADAPTERS: dict[tuple[str, str, str], Adapter] = {
    (a.engine, a.shape, a.protocol): a for a in [*_PYSIM, *_PEERS]}
#: the engines, in the table's order (pysim first)
ENGINES = tuple(dict.fromkeys(a.engine for a in ADAPTERS.values()))
#: the protocols, in the case schema's order
PROTOCOLS = pysim.PROTOCOLS
#: what an engine refuses whatever its deck, checked before its deck is looked up
ENGINE_LIMITS: dict[str, tuple[Limit, ...]] = {
    "pysim": (),
    "lammps": common.PEER_LIMITS,
    "lammps-body": (lammps.no_limit_damping, *common.PEER_LIMITS),
    "liggghts": common.PEER_LIMITS,
}


def _listing(engine: str) -> str:
    """``compress (spheres, rods), tapping (rods)``: what ``engine`` runs."""
    by_protocol: dict[str, list[str]] = {}
    for e, s, p in ADAPTERS:
        if e == engine:
            by_protocol.setdefault(p, []).append(s)
    return ", ".join(f"{p} ({', '.join(s)})" for p, s in by_protocol.items())


def _unsupported(engine: str, case: dict) -> str:
    """One line: the engine has no deck for the case's shape and protocol; what it runs,
    and which engines run that combination."""
    key = (shape(case), case["protocol"]["name"])
    others = ", ".join(e for e in ENGINES if (e, *key) in ADAPTERS) or "none"
    return (f"{engine} has no deck for {key[0]} under protocol '{key[1]}' (it runs "
            f"{_listing(engine)}; engines that run {key[0]} under '{key[1]}': {others})")


def lookup(engine: str, case: dict) -> Adapter:
    """The adapter that runs ``case`` on ``engine``; :class:`EngineError` when the engine
    cannot (:func:`supports` names why)."""
    reason = supports(engine, case)
    if reason:
        raise EngineError(reason)
    return ADAPTERS[(engine, shape(case), case["protocol"]["name"])]


def supports(engine: str, case: dict) -> str | None:
    """``None`` when the engine can run the case, else the reason it cannot (one line)."""
    if engine not in ENGINE_LIMITS:
        return f"unknown engine {engine!r}; valid: {', '.join(ENGINES)}"
    if "contact" not in case and (engine, shape(case), case["protocol"]["name"]) not in ADAPTERS:
        return _unsupported(engine, case)  # hard spheres: the peers' limits read the contact law
    for limit in ENGINE_LIMITS[engine]:
        reason = limit(engine, case)
        if reason:
            return reason
    adapter = ADAPTERS.get((engine, shape(case), case["protocol"]["name"]))
    if adapter is None:
        return _unsupported(engine, case)
    for limit in adapter.limits:
        reason = limit(engine, case)
        if reason:
            return reason
    return None


def deck(engine: str, case: dict) -> Path:
    """The input deck that runs a case on an engine."""
    return lookup(engine, case).deck_path()


def deck_vars(case: dict, engine: str) -> dict[str, str]:
    """``-var`` values of the case's deck (compression, tapping or deposition), with the
    normal-force clip of ``contact.limit_damping`` where the deck has one."""
    adapter = ADAPTERS.get((engine, shape(case), case["protocol"]["name"]))
    if adapter is None or adapter.variables is None:
        raise EngineError(_unsupported(engine, case) if adapter is None
                          else f"{engine} has no deck and no -var values")
    clip = adapter.clip(case) if adapter.clip else {}
    return {**adapter.variables(case), **clip}


def settles(engine: str, case: dict) -> bool:
    """Whether ``engine`` runs the compression case ``case`` as gravity settling
    (LIGGGHTS with rods: ``inputs/liggghts/in.rods.settle``)."""
    adapter = ADAPTERS.get((engine, shape(case), case["protocol"]["name"]))
    return adapter is not None and adapter.settles
