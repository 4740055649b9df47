"""The modified Lubachevsky-Stillinger (MLS) search for the closest jammed configuration
(Baranau & Tallarek 2014, Sec. III.B; the authors' code, ref. 40).

LS blocks (:mod:`pysim.hard.ls`: ``collisions_per_particle * N`` collisions, then the
velocities scaled back to the temperature) starting at the compression rate
``initial_rate`` (10). When a block's reduced pressure reaches ``pressure_max`` (1e12):

* if the rate is already at or below ``final_rate`` (1e-4), the search ends;
* otherwise the growth stops (rate 0) and blocks of equilibration run until a block's
  reduced pressure falls below ``pressure_max``; then the growth resumes at the rate
  divided by ``factor`` once more (``initial_rate / factor^k`` after the k-th
  equilibration; the paper's factor is 2);
* if ``max_equilibrations`` (50) equilibration blocks in a row all stay at or above
  ``pressure_max``, the packing is taken as jammed and the search ends.

The packing fraction at the end is the closest jamming density ``phi_J`` of the start.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

from pysim.hard.edmd import EDMD, Block

#: why a search ended
FINAL_RATE = "final_rate"
EQUILIBRATIONS = "equilibrations"


@dataclass
class MLS:
    """State and parameters of one MLS search; :meth:`step` runs one block."""
    initial_rate: float = 10.0
    factor: float = 2.0
    final_rate: float = 1e-4
    max_equilibrations: int = 50
    temperature: float = 0.2
    pressure_max: float = 1e12
    collisions_per_particle: int = 20
    rate: float | None = None      #: rate of the next block (0 while equilibrating)
    decreases: int = 0             #: equilibrations finished (rate divided this many times)
    equilibrations: int = 0        #: blocks of the current equilibration still above
    blocks: int = 0
    done: bool = False
    reason: str = ""               #: FINAL_RATE or EQUILIBRATIONS once done

    def __post_init__(self):
        if self.rate is None:
            self.rate = self.initial_rate

    def step(self, system: EDMD) -> Block:
        """One block at :attr:`rate`, the velocity rescaling, then the schedule."""
        system.rate = self.rate
        blk = system.block(self.collisions_per_particle * system.n)
        system.rescale(self.temperature)
        self.blocks += 1
        high = blk.reduced_pressure >= self.pressure_max
        if self.rate > 0.0:
            if high:
                if self.rate <= self.final_rate:
                    self.done, self.reason = True, FINAL_RATE
                else:
                    self.rate = 0.0
                    self.equilibrations = 0
        elif not high:
            self.decreases += 1
            self.rate = self.initial_rate / self.factor**self.decreases
        else:
            self.equilibrations += 1
            if self.equilibrations >= self.max_equilibrations:
                self.done, self.reason = True, EQUILIBRATIONS
        return blk

    def growth_rate(self) -> float:
        """The rate growth runs (or will resume) at: :attr:`rate`, or while equilibrating
        the next one."""
        return self.rate if self.rate > 0 else self.initial_rate / self.factor**(self.decreases + 1)

    def to_dict(self) -> dict:
        return asdict(self)
