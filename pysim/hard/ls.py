"""The Lubachevsky-Stillinger compression (refs. 36, 37 of Baranau & Tallarek 2014, with
the parameters of their Sec. III.B).

Event-driven dynamics (:class:`pysim.hard.edmd.EDMD`) with the diameters growing at the
compression rate ``gamma = dr/dt`` (``D_i(t) = r(t) D_i^nom``, nominal diameters of mean
1; unit masses, ``k_B = 1``), in blocks of ``collisions_per_particle * N`` collisions
(the paper: 20 per particle). After every block the reduced pressure ``Z`` of the block
is read and the velocities are scaled back to the temperature (0.2: rms speed
``sqrt(3 * 0.2)``), since every collision of growing spheres pushes them apart faster
than they met. The compression ends at the first block whose ``Z`` reaches
``pressure_max`` (1e12); the packing fraction then is the LS density ``phi``.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

from pysim.hard.edmd import EDMD, Block


@dataclass
class LS:
    """State and parameters of one LS compression; :meth:`step` runs one block."""
    rate: float                        #: gamma, 1 / time
    temperature: float = 0.2           #: k_B T
    pressure_max: float = 1e12         #: reduced pressure that ends the compression
    collisions_per_particle: int = 20  #: collisions per particle in a block
    blocks: int = 0
    done: bool = False

    def step(self, system: EDMD) -> Block:
        """One block at the compression rate, then the velocity rescaling; sets
        :attr:`done` once its reduced pressure reaches :attr:`pressure_max`."""
        system.rate = self.rate
        blk = system.block(self.collisions_per_particle * system.n)
        system.rescale(self.temperature)
        self.blocks += 1
        self.done = blk.reduced_pressure >= self.pressure_max
        return blk

    def to_dict(self) -> dict:
        return asdict(self)
